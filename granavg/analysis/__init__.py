"""From profiles to the paper: continuum checks (Eqs. 8-15), headline numbers and claims,
figures and the report."""
