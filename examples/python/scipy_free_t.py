"""The 0.975 quantile of Student's t, as `swarmfl report` uses it (no scipy needed)."""

_TABLE = [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179,
          2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064,
          2.060, 2.056, 2.052, 2.048, 2.045, 2.042]


def t_975(df: int) -> float:
    """Exact table values for df 1..30, 1.96 beyond (the report interpolates; close enough
    for error bars)."""
    return _TABLE[df - 1] if 1 <= df <= 30 else 1.96
