"""The course's subcommands of ``pbanim`` (added to the command line by :mod:`pbanim.cli`).

    pbanim assignment list                               one line per assignment (pending ones say why)
    pbanim assignment make NAME DIR [--force]            the starter folder (module, public tests, README)
    pbanim grade NAME PATH [--json F] [--markdown F]     per-check table; JSON and markdown reports
                     [--time-limit S] [--memory-mb M]    limits of each check's process
    pbanim grade … --format gradescope                   Gradescope's results.json instead (at --json)
    pbanim course student-edition OUT/ [--assignments A …]   a wheel without the solutions (pbanim.course.edition)
    pbanim course autograder NAME OUT.zip [--force]      Gradescope's autograder zip (pbanim.course.gradescope)
    pbanim course export NAME OUT/ [--format nbgrader] [--force]   nbgrader's source notebook,
                                                         OUT/source/NAME/NAME.ipynb (pbanim.course.nbgrader_export)
    pbanim notebook chNN DIR                             a chapter as a Jupyter notebook (chapters found
                                                         by the command line and handed in)

Every mistake a user can make here — an unknown assignment (closest names suggested), a missing file, a
folder that would be overwritten, a bad limit — ends as one ``pbanim: error: …`` line and exit code 2,
never a traceback; a student's broken module is a line *in the report* (the grade still completes).
Exit codes of ``grade``: 0 when it completed (whatever the score), 2 for bad arguments.
"""

from __future__ import annotations

from pathlib import Path

from ..contracts import call_checked   # what the command line passes comes from the user: checked
from ..errors import InvalidInput

__all__ = ["add_course_commands", "assignment_lines"]


def assignment_lines() -> list[str]:
    """One line per assignment: name, chapter, title, checks/points or the pending reason."""
    from . import assignments

    out = []
    for name, a in assignments().items():
        if a.status == "ready":
            hidden = sum(not c.public for c in a.checks)
            out.append(f"{name:22s} {a.title} — {len(a.checks)} checks ({hidden} hidden), "
                       f"{len(a.mutants)} known bugs caught; module {a.module}")
        else:
            out.append(f"{name:22s} {a.title} — pending: {a.pending_reason}")
    return out


def _cmd_assignment(args) -> int:
    if args.action == "list":
        print("\n".join(assignment_lines()))
        return 0
    if not args.name or not args.dir:
        raise InvalidInput("usage: pbanim assignment make NAME DIR (see `pbanim assignment list`)")
    from . import make_assignment

    files = make_assignment(args.name, args.dir, overwrite=args.force)
    for p in files:
        print(f"wrote {p}")
    print(f"next: cd {args.dir} && pytest . ; then `pbanim grade {args.name} {args.dir}`")
    return 0


def _cmd_grade(args) -> int:
    from .grader import grade

    rep = call_checked(grade, args.name, args.path, time_limit=args.time_limit, memory_mb=args.memory_mb)
    print(rep.table())
    folder = Path(args.path) if Path(args.path).is_dir() else Path(args.path).parent
    if args.format == "gradescope":
        import json

        from .gradescope import gradescope_results

        out = Path(args.json or folder / "results.json")
        out.write_text(json.dumps(gradescope_results(rep), indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
        print(f"Gradescope results: {out}")
        return 0
    json_path = args.json or folder / "report.json"
    md_path = args.markdown or folder / "report.md"
    rep.write(json_path, md_path)
    print(f"reports: {json_path}, {md_path}")
    return 0


def _cmd_course(args) -> int:
    if args.action == "student-edition":
        if len(args.args) != 1:
            raise InvalidInput("usage: pbanim course student-edition OUT/ [--assignments NAMES]")
        from .edition import build_edition

        wheel = call_checked(build_edition, args.args[0], args.assignments)
        print(f"wrote {wheel}\nstudents install it with: pip install {wheel.name}")
        return 0
    if args.action == "export":
        if len(args.args) != 2:
            raise InvalidInput("usage: pbanim course export NAME OUT/ [--format nbgrader] [--force]")
        from .nbgrader_export import export_assignment

        out = call_checked(export_assignment, args.args[0], args.args[1], args.format, overwrite=args.force)
        print(f"wrote {out}: nbgrader's source notebook; in {args.args[1]} run "
              f"`nbgrader generate_assignment {args.args[0]}` for the students' version")
        return 0
    if len(args.args) != 2:
        raise InvalidInput("usage: pbanim course autograder NAME OUT.zip [--force]")
    from .gradescope import write_autograder

    out = call_checked(write_autograder, args.args[0], args.args[1], overwrite=args.force)
    print(f"wrote {out}: upload it as the assignment's autograder (Gradescope: Configure Autograder, zip file)")
    return 0


def add_course_commands(sub, chapter_files) -> None:
    """Add ``assignment``, ``grade`` and ``notebook`` to the subparsers ``sub``.

    ``chapter_files()`` returns {"chNN_topic": path of chapters/chNN_topic.py} (the command line finds
    them); ``pbanim notebook ch08 DIR`` writes every chapter module whose name starts with ``ch08``.
    """
    a = sub.add_parser("assignment", help="list assignments, or write a student's starter folder",
                       description="pbanim assignment list | pbanim assignment make NAME DIR [--force]")
    a.add_argument("action", choices=["list", "make"])
    a.add_argument("name", nargs="?", help="assignment name (see `pbanim assignment list`)")
    a.add_argument("dir", nargs="?", help="folder to write the starter into")
    a.add_argument("--force", action="store_true", help="overwrite existing starter files")
    a.set_defaults(func=_cmd_assignment)

    g = sub.add_parser("grade", help="grade a student's module: per-check table, JSON and markdown reports")
    g.add_argument("name", help="assignment name")
    g.add_argument("path", help="the student's module file, or the starter folder")
    g.add_argument("--json", help="JSON report (default: report.json beside the module)")
    g.add_argument("--markdown", help="markdown report (default: report.md beside the module)")
    g.add_argument("--time-limit", type=float, default=20.0, help="seconds per check (CPU and wall clock)")
    g.add_argument("--memory-mb", type=float, default=1024.0, help="memory per check, MB")
    g.add_argument("--format", choices=["pbanim", "gradescope"], default="pbanim",
                   help="pbanim: report.json and report.md; gradescope: the platform's results.json (at --json)")
    g.set_defaults(func=_cmd_grade)

    c = sub.add_parser("course", help="a student edition of pbanim, an assignment's Gradescope autograder or its "
                                      "nbgrader notebook",
                       description="pbanim course student-edition OUT/ [--assignments NAMES] | "
                                   "pbanim course autograder NAME OUT.zip [--force] | "
                                   "pbanim course export NAME OUT/ [--format nbgrader] [--force]")
    c.add_argument("action", choices=["student-edition", "autograder", "export"])
    c.add_argument("args", nargs="*", help="student-edition: OUT/; autograder: NAME OUT.zip; export: NAME OUT/")
    c.add_argument("--assignments", nargs="+", help="student-edition: the assignments to remove (default all)")
    c.add_argument("--format", choices=["nbgrader"], default="nbgrader",
                   help="export: the platform (nbgrader; otter-grader is not exported, see pbanim.course.nbgrader_export)")
    c.add_argument("--force", action="store_true", help="autograder, export: overwrite the output")
    c.set_defaults(func=_cmd_course)

    n = sub.add_parser("notebook", help="write a chapter as a Jupyter notebook (.ipynb)")
    n.add_argument("chapter", help="chapter, e.g. ch01")
    n.add_argument("dir", help="output folder")

    def _cmd_notebook(args) -> int:
        from .notebook import write_notebook
        from .registry import closest

        files = chapter_files()
        chosen = [m for m in sorted(files) if len(args.chapter) >= 4 and m.startswith(args.chapter)]
        if not chosen:
            raise InvalidInput(f"unknown chapter {args.chapter!r}{closest(args.chapter, {m[:4] for m in files})}; "
                               f"available: {sorted({m[:4] for m in files})}")
        for m in chosen:
            print(f"wrote {write_notebook(files[m], args.dir)}")
        return 0

    n.set_defaults(func=_cmd_notebook)
