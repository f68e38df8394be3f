"""What every pleat-* command shares (docs/tools.md):

- A bad input is reported as ONE line on stderr, `PROG: error: FILE: what is wrong`, with exit status 1, and the
  command writes nothing (outputs go through pleat.fileio, after all inputs are read and checked). Loaders raise
  `InputError(path, problem)`; `command(prog, build_parser)` makes the console script's `main(argv)` from a
  `main(args)` and turns InputError, and OS errors on a named file, into that line. Any other exception is a bug: one
  line too, that says so (PLEAT_DEBUG=1 re-raises it for the traceback). argparse's usage errors, and UsageError for
  arguments that parse but do not go together, keep argparse's form and exit status 2.
- The same flags: `--quiet` (no progress bars or progress messages; `--no-progress` is its deprecated alias), and
  `--out` for where the command's output goes (help text says whether a file or a folder).
"""
import argparse
import functools
import os
import sys
from pathlib import Path

EXIT_INPUT_ERROR = 1
EXIT_INTERRUPTED = 130


class UsageError(Exception):
    """Arguments that parse but do not go together: reported as argparse reports its own (usage, exit status 2)."""


class InputError(ValueError):
    """A malformed or missing input: `path` (may be None) and what is wrong with it, in words."""

    def __init__(self, path, problem):
        self.path = None if path is None else str(path)
        self.problem = str(problem)
        super().__init__(self.problem if self.path is None else f"{self.path}: {self.problem}")


def one_line(text):
    """Collapses newlines (and the runs of spaces around them) so that a message stays on one line."""
    return "; ".join(" ".join(part.split()) for part in str(text).splitlines() if part.strip())


def error_message(exc):
    """The message of the one error line (without the `PROG: error: ` prefix)."""
    if isinstance(exc, InputError):
        return one_line(exc)
    if isinstance(exc, OSError) and exc.filename is not None:
        return one_line(f"{exc.filename}: {exc.strerror or exc}")
    return one_line(exc) or type(exc).__name__


def command(prog, build_parser=None):
    """Decorator for a console script's main: bad inputs → one line on stderr and exit status 1. With build_parser,
    main(args) gets the parsed arguments (the wrapped script still takes argv) and may raise UsageError; without it,
    main(argv) parses its own. A main that returns None exits with 0."""
    def wrap(main):
        @functools.wraps(main)
        def run(argv=None):
            parser = None
            try:
                if build_parser is None:
                    status = main(argv)
                else:
                    parser = build_parser()
                    status = main(parser.parse_args(argv))
                return 0 if status is None else status
            except UsageError as exc:
                if parser is None:
                    raise
                parser.error(str(exc))
            except BrokenPipeError:          # `pleat-motion list | head`: the reader left; not an error to report
                os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
                return EXIT_INPUT_ERROR
            except (InputError, OSError) as exc:
                print(f"{prog}: error: {error_message(exc)}", file=sys.stderr)
                return EXIT_INPUT_ERROR
            except KeyboardInterrupt:
                print(f"{prog}: interrupted", file=sys.stderr)
                return EXIT_INTERRUPTED
            except Exception as exc:   # noqa: BLE001 - a bug, reported on one line unless PLEAT_DEBUG asks for more
                if os.environ.get("PLEAT_DEBUG"):
                    raise
                print(f"{prog}: internal error: {type(exc).__name__}: {error_message(exc)} "
                      "(PLEAT_DEBUG=1 shows the traceback)", file=sys.stderr)
                return EXIT_INPUT_ERROR
        run.prog = prog
        return run
    return wrap


def not_npz(path, exc, what):
    """The InputError for an npz that numpy could not read: a plain 'not an npz' when it is no zip archive (numpy
    would talk about pickles), else what numpy said."""
    import zipfile
    if not zipfile.is_zipfile(path):
        return InputError(path, f"not {what}: not an npz file (not a zip archive)")
    return InputError(path, f"not {what} ({type(exc).__name__}: {exc})")


def read_by_suffix(path, readers, what, error=InputError):
    """`path` read by the reader for its suffix (`readers`: {".obj": read_obj, ...}, lower case), or `error` naming
    the file when it is missing, not a regular file, or of a suffix no reader takes (`what`: "mesh", ...)."""
    path = Path(path)
    if not path.is_file():
        raise error(path, f"no such {what} file" if not path.exists() else "is not a regular file")
    reader = readers.get(path.suffix.lower())
    if reader is None:
        *rest, last = readers
        raise error(path, f"unknown {what} format {path.suffix or '(no suffix)'!r}: use "
                          + (f"{', '.join(rest)} or {last}" if rest else last))
    return reader(path)


def doc_parser(prog, doc):
    """A parser whose description is the module docstring's first paragraph and whose epilog is all of it, verbatim."""
    return argparse.ArgumentParser(prog=prog, description=doc.split("\n\n")[0],
                                   formatter_class=argparse.RawDescriptionHelpFormatter, epilog=doc)


def add_quiet(parser):
    """--quiet, and --no-progress as its deprecated alias (same destination: args.quiet)."""
    parser.add_argument("--quiet", action="store_true", help="no progress bars or progress messages")
    parser.add_argument("--no-progress", dest="quiet", action="store_true",
                        help="deprecated alias of --quiet")
    return parser


def progress_note(args, message):
    """A progress message on stderr unless --quiet."""
    if not getattr(args, "quiet", False):
        print(message, file=sys.stderr, flush=True)


def parse_floats(text, count=None, what="value"):
    """"1,2,3" (or spaces) → floats; an argparse-friendly error naming the option otherwise."""
    if text is None:
        return None
    try:
        parts = [float(p) for p in str(text).replace(" ", ",").split(",") if p != ""]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{what} needs comma-separated numbers, got {text!r}") from None
    if count is not None and len(parts) != count:
        raise argparse.ArgumentTypeError(f"{what} needs {count} comma-separated numbers, got {text!r}")
    return parts


def positive_float(text):
    """argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (value > 0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"{text!r} must be a positive number")
    return value
