"""The child side of the sandbox: runs one program, then exits.

Started by the host as `python -I -S -B worker.py RFD WFD`, so it imports only the standard library (no
site-packages, no attribot, no numpy) and starts fast; the host keeps one started ahead of need. It holds
only stubs and plain data: every API call is a JSON line to the host on the WFD pipe, answered on RFD.

Inside: the program's code (checked and compiled by the host, sent marshalled), a builtins dict of
harmless functions and the bomb guards the compiler inserted calls to (`worker_guards.py`), stubs of the
host's objects (`worker_stubs.py`), and resource limits (address space, CPU, no new file descriptors, no
file writes). A stop (limit, time-out, API error) is a `SandboxStop`, a `BaseException` that no program
can catch; the first one is also recorded, so it is reported even if something swallowed it (the worker's
state, its stops and its pipe to the host: `worker_pipe.py`).
"""

from __future__ import annotations

import binascii
import builtins
import fcntl
import marshal
import os
import resource
import signal
import sys

try:  # imported by the host as part of the package
    from attribot.runner.protocol import KIND, PROGRAM_FILENAME, Key, Kind, WireLimits
    from attribot.runner.worker_guards import (
        SAFE_BUILTIN_NAMES,
        g_add,
        g_iadd,
        g_ilshift,
        g_imul,
        g_ipow,
        g_lshift,
        g_mul,
        g_pow,
        make_math,
        make_typing,
        safe_import,
        safe_pow,
        safe_round,
    )
    from attribot.runner.worker_pipe import (
        STATE,
        ActionFailed,
        Channel,
        SandboxStop,
        dumps,
        exchange,
        on_timer,
        stop,
    )
    from attribot.runner.worker_stubs import (
        Unsupported,
        call_entry,
        decode,
        encode,
        make_function,
        stub_class,
    )
except ImportError:  # run as a script with -I -S (no site-packages, no script folder on the path)
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from protocol import KIND, PROGRAM_FILENAME, Key, Kind, WireLimits  # type: ignore[no-redef]
    from worker_guards import (  # type: ignore[no-redef]
        SAFE_BUILTIN_NAMES,
        g_add,
        g_iadd,
        g_ilshift,
        g_imul,
        g_ipow,
        g_lshift,
        g_mul,
        g_pow,
        make_math,
        make_typing,
        safe_import,
        safe_pow,
        safe_round,
    )
    from worker_pipe import (  # type: ignore[no-redef]
        STATE,
        ActionFailed,
        Channel,
        SandboxStop,
        dumps,
        exchange,
        on_timer,
        stop,
    )
    from worker_stubs import (  # type: ignore[no-redef]
        Unsupported,
        call_entry,
        decode,
        encode,
        make_function,
        stub_class,
    )

    del sys.path[0]

# every module the worker needs is imported above: once the channel is set up the process can open no
# file, so nothing may be imported later

__all__ = ["main"]

CHANNEL_FDS = (3, 4)


def safe_print(*args, sep=" ", end="\n", file=None, flush=False):
    if file is not None:
        raise TypeError("print() writes to the program's output only: drop file=")
    if sep is None:
        sep = " "
    if end is None:
        end = "\n"
    if type(sep) is not str or type(end) is not str:
        raise TypeError("print(): sep and end must be strings")
    text = sep.join(str(a) for a in args) + end
    if not text:
        return
    room = STATE.max_out - STATE.out_len
    if len(text) > room:
        if room > 0:
            STATE.out_len += room
            exchange(dumps({KIND: Kind.OUT, Key.TEXT: text[:room]}), reply=False)
        stop("limit", f"output limit reached: programs may print at most {STATE.max_out} characters")
    STATE.out_len += len(text)
    exchange(dumps({KIND: Kind.OUT, Key.TEXT: text}), reply=False)


def build_globals():
    safe = {name: getattr(builtins, name) for name in SAFE_BUILTIN_NAMES}
    safe["print"] = safe_print
    safe["pow"] = safe_pow
    safe["round"] = safe_round
    safe["__import__"] = safe_import
    STATE.math = make_math()
    STATE.typing, STATE.future = make_typing()
    safe["ActionFailed"] = ActionFailed
    for name, cls in STATE.stub_types.items():  # isinstance(x, ImagePatch); ImagePatch(image)
        safe[name] = cls
    for owner, methods in STATE.owners.items():  # go_to_object("book"); a program's own names win
        for method in methods:
            safe.setdefault(method, make_function(owner, method))
    return {
        "__builtins__": safe,
        "__name__": "program",
        "_sb_pow": g_pow,
        "_sb_mul": g_mul,
        "_sb_lshift": g_lshift,
        "_sb_ipow": g_ipow,
        "_sb_imul": g_imul,
        "_sb_ilshift": g_ilshift,
        "_sb_add": g_add,
        "_sb_iadd": g_iadd,
        "_sb_slice": slice,
    }


# ---- one run ---------------------------------------------------------------------------------------


def error_line(exc):
    line = None
    tb = exc.__traceback__
    while tb is not None:
        if tb.tb_frame.f_code.co_filename == PROGRAM_FILENAME:
            line = tb.tb_lineno
        tb = tb.tb_next
    return line


def describe(exc, limits):
    if isinstance(exc, SandboxStop):
        return exc.category, exc.message
    if type(exc) is ActionFailed:  # not caught: the API's error, as a stop would have reported it
        return "api", str(exc)
    if isinstance(exc, MemoryError):
        return "limit", f"memory limit reached: the program may use about {limits.memory_mb} MB"
    if isinstance(exc, RecursionError):
        return "limit", f"recursion too deep: at most {limits.max_recursion} nested calls"
    if isinstance(exc, OSError):  # e.g. a codec that would load a module from disk
        return "runtime", f"{type(exc).__name__}: programs cannot open files or load modules"
    try:
        text = str(exc)
    except BaseException:  # noqa: BLE001 (a message that cannot be made is no reason to fail)
        text = ""
    text = text if len(text) <= 500 else text[:497] + "..."
    return "runtime", f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def apply_limits(limits):
    signal.signal(signal.SIGALRM, on_timer("timeout", f"the program ran longer than {limits.wall_s} s"))
    signal.signal(
        signal.SIGPROF, on_timer("timeout", f"the program used more than {limits.cpu_s} s of CPU time")
    )
    mem = limits.memory_mb * 1024 * 1024
    resource.setrlimit(resource.RLIMIT_AS, (mem, mem))
    used = resource.getrusage(resource.RUSAGE_SELF)
    cpu = int(used.ru_utime + used.ru_stime + limits.cpu_s) + 2
    resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 1))  # backstop: the kernel kills past it
    signal.setitimer(signal.ITIMER_PROF, limits.cpu_s)
    signal.setitimer(signal.ITIMER_REAL, limits.wall_s)


def stop_timers():
    signal.setitimer(signal.ITIMER_REAL, 0)
    signal.setitimer(signal.ITIMER_PROF, 0)


def run(request):
    """Run the program; return the final message for the host (raises only if a timer lands late)."""
    limits = WireLimits.from_wire(request[Key.LIMITS])
    STATE.max_out = limits.max_output_chars
    STATE.max_bits = limits.max_int_bits
    STATE.max_seq = limits.max_sequence
    STATE.max_msg = limits.max_message_bytes
    STATE.classes = {name: tuple(methods) for name, methods in request[Key.CLASSES].items()}
    functions = request.get(Key.FUNCTIONS) or {}
    STATE.owners = {owner: dict(spec[Key.FN_METHODS]) for owner, spec in functions.items()}
    borrowed = {}
    for owner, spec in functions.items():
        for on, methods in spec[Key.FN_ON].items():
            borrowed.setdefault(on, []).extend((owner, m, spec[Key.FN_METHODS][m]) for m in methods)
    STATE.stub_types = {
        name: stub_class(name, methods, borrowed.get(name, ())) for name, methods in STATE.classes.items()
    }
    STATE.borrowers = set(borrowed)
    code = marshal.loads(binascii.a2b_base64(request[Key.CODE]))
    g = build_globals()
    args = [decode(a) for a in request[Key.ARGS]]
    for cls_name, (wire, method) in (request.get(Key.CONSTRUCTORS) or {}).items():
        STATE.constructors[cls_name] = (decode(wire), method)
    entry = request[Key.ENTRY]
    sys.setrecursionlimit(len_stack() + limits.max_recursion + 10)
    apply_limits(limits)
    try:
        exec(code, g)  # noqa: S102 (the code was checked and compiled by the host)
        fn = g.get(entry)
        if not callable(fn):
            raise TypeError(f"{entry} is not a function")
        value = call_entry(fn, args, entry)
        if STATE.stopped is not None:
            raise STATE.stopped
        try:
            msg = dumps({KIND: Kind.DONE, Key.VALUE: encode(value)})
        except Unsupported as e:
            msg = error_message(
                "runtime",
                f"{entry} returned a {e}; return an API object, a number, a "
                "string, a bool or a list of those",
                None,
            )
        except (ValueError, RecursionError) as e:
            msg = error_message(
                "limit",
                f"{entry} returned a value that cannot be passed back ({type(e).__name__}: {str(e)[:200]})",
                None,
            )
    except BaseException as exc:  # noqa: BLE001 (every failure becomes a structured error)
        category, message = describe(exc, limits)
        msg = error_message(category, message, error_line(exc))
        del exc
    STATE.critical = True
    stop_timers()
    g.clear()
    return msg


def error_message(category, message, line):
    first = STATE.stopped
    if first is not None and category != first.category:
        category, message = first.category, first.message  # a stop that something swallowed
    return dumps({KIND: Kind.FAILED, Key.CATEGORY: category, Key.MESSAGE: message, Key.LINE: line})


def len_stack():
    depth, frame = 0, sys._getframe()
    while frame is not None:
        depth += 1
        frame = frame.f_back
    return depth


def setup_channel(rfd, wfd):
    """Move the pipe ends to fds 3 and 4, close everything else, and allow no new descriptors."""
    hi_r = fcntl.fcntl(rfd, fcntl.F_DUPFD, 64)
    hi_w = fcntl.fcntl(wfd, fcntl.F_DUPFD, 64)
    os.close(rfd)
    os.close(wfd)
    os.dup2(hi_r, CHANNEL_FDS[0])
    os.dup2(hi_w, CHANNEL_FDS[1])
    os.closerange(CHANNEL_FDS[1] + 1, 4096)
    resource.setrlimit(resource.RLIMIT_NOFILE, (CHANNEL_FDS[1] + 1, CHANNEL_FDS[1] + 1))
    resource.setrlimit(resource.RLIMIT_FSIZE, (0, 0))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    return Channel(CHANNEL_FDS[0], CHANNEL_FDS[1])


def main(argv):
    STATE.chan = setup_channel(int(argv[1]), int(argv[2]))
    STATE.chan.send({KIND: Kind.READY})
    request = STATE.chan.recv()
    if request.get(KIND) != Kind.RUN:
        os._exit(2)
    STATE.chan.send({KIND: Kind.GO})
    limits = WireLimits.from_wire(request[Key.LIMITS])
    try:
        try:
            msg = run(request)
        except BaseException as exc:  # noqa: BLE001 (a timer that fired during the clean-up)
            STATE.critical = True
            stop_timers()
            category, message = describe(STATE.stopped or exc, limits)
            msg = error_message(category, message, error_line(exc))
        STATE.chan.send_raw(msg)
    finally:
        os._exit(0)  # no clean-up code of any kind runs after the program


if __name__ == "__main__":
    main(sys.argv)
