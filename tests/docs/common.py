"""Helpers the docs tests share."""


def strings(value):
    """Every string in a JSON value (dicts and lists walked), to look for paths in results."""
    if isinstance(value, dict):
        for v in value.values():
            yield from strings(v)
    elif isinstance(value, list):
        for v in value:
            yield from strings(v)
    elif isinstance(value, str):
        yield value
