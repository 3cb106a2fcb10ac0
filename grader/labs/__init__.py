"""Exercise specifications, one module per lab."""
