"""Data package drake_tooluse.scenarios; a regular package so an editable install maps it."""
