"""F8 (script reload): the add-on's one module list (MODULES in __init__.py) reloads every module,
lower layers first, and the reloaded add-on registers and evaluates as before."""
import inspect

from addon_helpers import close, evaluated, make_object, twin_with_simple_deform


def own_definitions(module):
    """The functions and classes a module defines itself (not those it imports)."""
    return {name: value for name, value in vars(module).items()
            if (inspect.isfunction(value) or inspect.isclass(value)) and value.__module__ == module.__name__}


def test_a_script_reload_runs_every_module_again_and_the_addon_still_works(scene, addon):
    import importlib

    import bpy
    before = {module.__name__: own_definitions(module) for module in addon._loaded}
    assert [module.__name__ for module in addon._loaded] == [f"{addon.__name__}.{n}" for n in addon.MODULES]
    addon.unregister()
    try:
        importlib.reload(addon)
    finally:
        addon.register()
    after = {module.__name__: module for module in addon._loaded}
    assert list(after) == list(before)
    # A module run again defines new function and class objects: none is the one from before.
    stale = [f"{name}.{attr}" for name, defined in before.items() for attr, value in defined.items()
             if getattr(after[name], attr, None) is value]
    assert stale == []
    assert all(cls.is_registered for cls in addon.classes)

    from deformkit_addon import api
    obj = make_object(bpy)
    api.add_entry(obj, "TWIST", angle=1.1, deform_axis="Z")
    twin = twin_with_simple_deform(bpy, obj, deform_method="TWIST", angle=1.1, deform_axis="Z")
    assert close(evaluated(obj), evaluated(twin))
