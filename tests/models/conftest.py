"""One BLAS thread for the learner tests.

The least-squares steps here are small (at most a few thousand x 100);
OpenBLAS's two spinning threads only slow them down, by 10-100x when other
processes share the two cores.
"""

import pytest
from threadpoolctl import threadpool_limits


@pytest.fixture(autouse=True, scope="package")
def _one_blas_thread():
    with threadpool_limits(limits=1, user_api="blas"):
        yield
