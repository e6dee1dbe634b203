"""Package data: the MJCF quadrotor (a package so that wheels include it)."""
