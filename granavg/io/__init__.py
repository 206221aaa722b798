"""Files and run directories: dump readers, contact conversion, profile tables, run
manifests, validation at the way in, and averaging a run (or several) from its files."""
