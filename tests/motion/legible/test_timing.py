"""The corollary's operation counts: legible LQR costs at most twice plain LQR, and both grow with N."""


def test_operation_counts_of_the_corollary():
    from mutual.motion.legible import timing
    table = timing.corollary_operation_counts((16, 64))
    assert (table["ratio legible / plain"] > 1.0).all() and (table["ratio legible / plain"] <= 2.0).all()
    assert table["plain LQR (flops)"].iloc[1] > 2 * table["plain LQR (flops)"].iloc[0]    # grows with N
