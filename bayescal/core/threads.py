"""Thread limits for the small linear algebra of likelihoods and fits."""


def single_threaded_blas():
    """Context limiting BLAS to one thread. The likelihood's products are
    small (walkers x nodes x bands): threaded BLAS only adds latency, and on a
    busy machine its threads wait on each other (measured: 18 ms against
    0.12 ms per call on 2 loaded cores)."""
    from threadpoolctl import threadpool_limits
    return threadpool_limits(limits=1, user_api="blas")
