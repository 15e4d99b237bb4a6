"""The add-on's one exception type, at the bottom of its layers so that every module may raise it."""


class EntryError(ValueError):
    """A problem with one entry's settings or input, shown on the entry."""
