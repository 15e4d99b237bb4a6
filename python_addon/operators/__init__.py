"""The operator layer: what the panel, the menus and the key map run, each a thin wrapper naming
the api (or evaluation) function it calls. One module per subject; base.py owns the error reporting."""
from . import cage, laplacian, lattice, rbf, stack, transfer

classes = stack.classes + lattice.classes + laplacian.classes + cage.classes + rbf.classes + transfer.classes
register_keymaps, unregister_keymaps = stack.register_keymaps, stack.unregister_keymaps
register_menus, unregister_menus = transfer.register_menus, transfer.unregister_menus
