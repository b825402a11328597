from gyrocomp.cli import main

main()
