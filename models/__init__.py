"""Data package drake_tooluse.models; a regular package so an editable install maps it."""
