"""The operator layer: what the panel, the menus and the key map run, each a thin wrapper naming
the api (or evaluation) function it calls; one module per subject, registered by the add-on's
module list. base.py owns the error reporting."""
