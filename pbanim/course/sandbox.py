"""Run one check of a student's module in a child process with time and memory limits.

Each check runs in its own process, forked from the grader (numpy, scipy and pbanim are already loaded,
so a check costs milliseconds of start-up, not an interpreter). The child

1. sets its limits with ``resource.setrlimit``: CPU seconds (``RLIMIT_CPU``; the kernel ends the child
   with SIGXCPU) and address space (``RLIMIT_AS`` = what the child already maps + the memory budget, so
   a runaway allocation raises MemoryError instead of swapping the machine),
2. sends its stdout and stderr to /dev/null (a student's prints do not reach the report),
3. loads the student file under a private module name (its ``@contract`` decorators made lenient about
   parameters the student renamed: :func:`lenient_contracts`), runs the check, and writes one JSON line
   {status, message} into a pipe, then leaves with ``os._exit`` (no atexit handlers of student code).

The parent waits on the pipe with a wall-clock deadline (a student ``time.sleep`` uses no CPU) and kills
the child when it passes. Whatever the student code does — an infinite loop, ``sys.exit``, ``os._exit``,
a segfault in a C extension, a MemoryError — costs that check and nothing else: the outcome is one of

==================  ===========================================================================
status              meaning
==================  ===========================================================================
passed              the oracle holds; message = what was measured
failed              the oracle does not hold (CheckFailed), or the result has the wrong shape
not_implemented     a NotImplementedError from a region the student has not written yet
error               an exception in student code (type, message, file:line of the last student frame)
import_error        the student file does not import (syntax error, missing name, exception)
timeout             the time limit passed (CPU or wall clock)
crashed             the child ended without a result (os._exit, a signal, memory exhausted)
==================  ===========================================================================

``isolation="inline"`` runs the same function in the grader's own process (no limits: for debugging
and for platforms without ``fork``). Messages never contain absolute paths or timings, so reports
are deterministic (ORACLES G2).
"""

from __future__ import annotations

import importlib.util
import json
import os
import select
import signal
import sys
import time
import traceback
from pathlib import Path

from ..contracts import lenient_signatures
from .registry import Assignment, CheckFailed

__all__ = ["run_isolated", "run_forked", "run_inline", "load_student", "STATUSES", "StudentImportError"]

STATUSES = ("passed", "failed", "not_implemented", "error", "import_error", "timeout", "crashed")
_MAX_MESSAGE = 400


def _short(text: str) -> str:
    text = " ".join(str(text).split())
    return text if len(text) <= _MAX_MESSAGE else text[:_MAX_MESSAGE - 1] + "…"


class StudentImportError(Exception):
    """The student's file could not be loaded; the message is the report line."""


def load_student(path: str | Path, tag: str = "student"):
    """Import the student's file under the private name ``_pbanim_student_<tag>``, or
    :class:`StudentImportError` with the one report line (file name and line only, no absolute path)."""
    path = Path(path)
    name = f"_pbanim_student_{tag}"
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise StudentImportError(f"{path.name} is not a Python file")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod                      # dataclasses and pickling look the module up by name
    try:
        try:
            # a student who changed a marked function's signature reads "wrong signature" when the check calls
            # it, not the contract's complaint at import that it names a parameter that is gone
            with lenient_signatures():
                spec.loader.exec_module(mod)
        except BaseException:
            sys.modules.pop(name, None)
            raise
    except SyntaxError as exc:
        raise StudentImportError(f"{path.name} does not import: SyntaxError at line {exc.lineno}: {exc.msg}") from None
    except SystemExit as exc:
        raise StudentImportError(f"{path.name} calls sys.exit({exc.code}) while being imported") from None
    except BaseException as exc:  # noqa: BLE001 - anything student code raises at import is a report line
        raise StudentImportError(f"{path.name} does not import: {type(exc).__name__}: {exc}"
                                 f"{_where(exc, path)}") from None
    return mod


def _where(exc: BaseException, path: Path) -> str:
    """" (at name.py:LINE in FUNC)" for the last traceback frame inside the student file, else ""."""
    frames = [f for f in traceback.extract_tb(exc.__traceback__) if Path(f.filename).name == path.name]
    if not frames:
        return ""
    f = frames[-1]
    return f" (at {path.name}:{f.lineno} in {f.name})"


def run_inline(assignment: Assignment, check_id: str, path: str | Path) -> dict:
    """Run one check here and now; returns {"status", "message"} (never raises for student faults)."""
    path = Path(path)
    chk = assignment.get_check(check_id)
    try:
        mod = load_student(path, f"{assignment.name}_{os.getpid()}")
    except StudentImportError as exc:
        return {"status": "import_error", "message": _short(str(exc))}
    try:
        from .edition import substitute_student

        substitute_student(assignment, mod)      # a student edition: pbanim's code runs on the student's
        return _classify(chk, mod, path)
    except Exception as exc:  # noqa: BLE001 - a student's exception is a report line, not a traceback
        hint = " (wrong signature?)" if isinstance(exc, TypeError) and "argument" in str(exc) else ""
        return {"status": "error", "message": _short(f"{type(exc).__name__}: {exc}{hint}{_where(exc, path)}")}


def _not_implemented_cause(exc: BaseException) -> BaseException | None:
    """The NotImplementedError in the cause/context chain of ``exc`` (pbanim wrapped it), or None."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        seen.add(id(exc))
        if isinstance(exc, NotImplementedError):
            return exc
        exc = exc.__cause__ or exc.__context__
    return None


def _classify(chk, mod, path: Path) -> dict:
    """Run the check; map the expected outcomes (pass, CheckFailed, not implemented, exits) to a result.
    Any other exception propagates to :func:`run_inline`, which reports it as an error."""
    try:
        msg = chk.func(mod)
        return {"status": "passed", "message": _short(msg or "oracle met")}
    except NotImplementedError as exc:
        return {"status": "not_implemented",
                "message": _short(f"not implemented yet: {exc}" if str(exc) else
                                  f"not implemented yet (regions {', '.join(chk.regions)})")}
    except CheckFailed as exc:
        return {"status": "failed", "message": _short(str(exc))}
    except SystemExit as exc:
        return {"status": "error", "message": f"student code called sys.exit({exc.code})"}
    except MemoryError:
        return {"status": "crashed", "message": "memory limit exceeded (MemoryError)"}
    except RecursionError as exc:
        return {"status": "error", "message": "RecursionError: maximum recursion depth exceeded" + _where(exc, path)}
    except Exception as exc:  # noqa: BLE001 - pbanim code may wrap a student's NotImplementedError
        inner = _not_implemented_cause(exc)
        if inner is None:
            raise
        return {"status": "not_implemented", "message": _short(f"not implemented yet: {inner}")}


def _vm_bytes() -> int:
    """Bytes the current process maps (VmSize), 0 when unknown."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmSize:"):
                return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


def _limit(cpu_seconds: float, memory_mb: float) -> None:
    import resource

    cpu = max(1, int(round(cpu_seconds)))
    resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 1))
    base = _vm_bytes()
    if base:
        cap = base + int(memory_mb * 2**20)
        resource.setrlimit(resource.RLIMIT_AS, (cap, cap))


def run_isolated(assignment: Assignment, check_id: str, path: str | Path, *, time_limit: float = 20.0,
                 memory_mb: float = 1024.0) -> dict:
    """Run one check in a forked child with the limits above; returns {"status", "message"}."""
    return run_forked(run_inline, (assignment, check_id, path), time_limit=time_limit, memory_mb=memory_mb)


def run_forked(fn, args: tuple, *, time_limit: float = 20.0, memory_mb: float = 1024.0) -> dict:
    """``fn(*args)`` (which returns a JSON-able dict {"status", "message"}) in a forked child with the
    limits above; a child that ends without a result gives "timeout" or "crashed"."""
    if not hasattr(os, "fork"):  # pragma: no cover - Windows: no isolation
        return fn(*args)
    rfd, wfd = os.pipe()
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid == 0:  # the child: never returns
        code = 0
        try:
            os.close(rfd)
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, 1)
            os.dup2(null, 2)
            _limit(time_limit, memory_mb)
            out = fn(*args)
            data = (json.dumps(out) + "\n").encode()
            while data:
                data = data[os.write(wfd, data):]
        except BaseException:  # noqa: BLE001 - the parent reports "crashed"
            code = 3
        finally:
            os._exit(code)
    os.close(wfd)
    chunks: list[bytes] = []
    deadline = time.monotonic() + 1.5 * time_limit + 2.0
    timed_out = False
    try:
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                timed_out = True
                break
            ready, _, _ = select.select([rfd], [], [], left)
            if not ready:
                continue
            chunk = os.read(rfd, 65536)
            if not chunk:
                break
            chunks.append(chunk)
    finally:
        os.close(rfd)
    if timed_out:
        os.kill(pid, signal.SIGKILL)
    _, status = os.waitpid(pid, 0)
    text = b"".join(chunks).decode(errors="replace").strip()
    if text:
        try:
            return json.loads(text.splitlines()[-1])
        except ValueError:
            pass
    if timed_out:
        return {"status": "timeout", "message": f"time limit exceeded ({time_limit:g} s): an endless loop, or "
                                                "a step or iteration count far too large"}
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        if sig == getattr(signal, "SIGXCPU", -1):
            return {"status": "timeout", "message": f"CPU time limit exceeded ({time_limit:g} s): an endless loop?"}
        name = signal.Signals(sig).name if sig in signal.Signals._value2member_map_ else str(sig)
        return {"status": "crashed", "message": f"the check process was killed by {name} (a crash, or memory "
                                                f"beyond {memory_mb:g} MB)"}
    code = os.WEXITSTATUS(status) if os.WIFEXITED(status) else -1
    return {"status": "crashed", "message": f"the check process ended with exit code {code} and no result "
                                            "(os._exit or an interpreter crash in student code)"}
