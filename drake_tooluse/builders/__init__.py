"""Builders that wire systems to the world, each returning a dataclass of named parts, and the runs of them."""
