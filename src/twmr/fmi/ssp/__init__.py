"""SSP (System Structure and Parameterization): systems read from and written to .ssp files."""
