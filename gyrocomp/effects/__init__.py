"""What the simulator, the diagnosis and the grey-box model share: the effects of a gyro's bias.

The three depend on this package and on none of each other:

* :mod:`gyrocomp.effects.shapes`: the deterministic bias shapes in physical
  units (element temperature, dT/dt, hysteresis relay and play, warm-up,
  rate ramp, periodic, the temperature polynomial), vectorised over a record;
* :mod:`gyrocomp.effects.vocabulary`: one object per effect of DESIGN.md's
  vocabulary, with its settings, its bias, its design columns and its report;
* :mod:`gyrocomp.effects.noise`: white, flicker, Gauss-Markov and random-walk
  rate noise drawn from IEEE 952's ``N``, ``B``, ``K``;
* :mod:`gyrocomp.effects.likelihood`: the noise model (white, flicker or
  Gauss-Markov, random walk) and the block-mean likelihood the diagnosis and
  the grey-box model select terms by;
* :mod:`gyrocomp.effects._stateful`: the shapes that carry state (element
  temperature, a causal dT/dt, the play) one sample at a time, for causal
  compensation.
"""
