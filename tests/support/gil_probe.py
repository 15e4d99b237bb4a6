"""Does a C function release the GIL while it works? `stamps_inside(fn, *args)` calls fn in this
thread while another Python thread stamps, and counts only the stamps taken while this thread is
inside fn's own C code: after the interpreter's "c_call" event for fn and before its
"c_return", with this thread's current Python frame the caller's (not a Python function fn
calls back, such as numpy's buffer-format parser, nor the profile hook itself). The stamping
thread needs the GIL to take a stamp, so a stamp there is possible only if fn released it;
a function that holds it gives 0 stamps however long it runs and however loaded the machine is.
Nothing is decided by the clock: a releasing call is repeated (a bounded number of times, a hang
guard) until the stamping thread has been scheduled inside one.

Give inputs that need no conversion (float64, C-contiguous): numpy releases the GIL in large
casts and copies, which would be stamps inside fn that its binding did not earn."""
import inspect
import sys
import threading


def _entry(fn, args):
    """The builtin the interpreter reports (c_call) and its arguments: a bound method is called
    through its function with self first, as the interpreter's own method call does, and a
    pybind11 class through its __init__ on a new instance, so that a constructor's work is probed
    like a method's. deformkit's Python wrapper (it only renames errors) is stepped over."""
    if isinstance(fn, type):
        fn, args = fn.__init__, (fn.__new__(fn), *args)
    elif inspect.ismethod(fn):
        fn, args = fn.__func__, (fn.__self__, *args)
    return inspect.unwrap(fn), args  # past deformkit's argument-naming wrapper (functools.wraps)


def stamps_once(fn, *args, **kwargs):
    """(stamps inside fn's C code, fn's result) for one call of fn(*args, **kwargs)."""
    target, args = _entry(fn, args)
    caller = sys._getframe()
    main = threading.get_ident()
    state = {"inside": False, "stop": False, "stamps": 0}
    started = threading.Event()

    def profile(frame, event, arg):
        if arg is target and event == "c_call":
            state["inside"] = True  # the last store before the C function runs: no switch point after it
        elif arg is target and event in ("c_return", "c_exception"):
            state["inside"] = False

    def stamp():
        started.set()
        while not state["stop"]:
            if state["inside"] and sys._current_frames().get(main) is caller:
                state["stamps"] += 1

    thread = threading.Thread(target=stamp, daemon=True)
    thread.start()
    started.wait()
    sys.setprofile(profile)
    try:
        result = target(*args, **kwargs)
    finally:
        sys.setprofile(None)
        state["stop"] = True
        thread.join()
    return state["stamps"], result


def stamps_inside(fn, *args, calls=200, **kwargs):
    """Stamps inside the first of at most `calls` calls of fn that had any (0 if none had). fn: a
    builtin, a bound method of a pybind11 object, or a pybind11 class (its constructor)."""
    for _ in range(calls):
        stamps, _ = stamps_once(fn, *args, **kwargs)
        if stamps:
            return stamps
    return 0

