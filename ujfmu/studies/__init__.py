"""Studies that re-run the papers' published results on the FMUs."""
