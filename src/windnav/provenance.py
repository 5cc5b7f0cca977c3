"""The command line that wrote a result file, rebuilt from the file itself.

Every ``--json`` document a command writes records ``command`` (``"windnav NAME"``),
``arguments`` (its parsed command line) and, since 2026-12-06, ``argv`` (the words as typed;
:func:`windnav.experiments.results.document`). :func:`command_line` gives the typed line where
the document has it, and otherwise rebuilds one from ``arguments`` that the current
command-line interface parses to the same arguments, so a committed result names the one
command that reproduces it without a document having to copy it out by hand. An option the
current interface no longer has is an error naming it, not a line that would run something
else::

    >>> from windnav.provenance import command_line
    >>> command_line("docs/data/decoder_eval_windinet.json")  # doctest: +SKIP
    'windnav evaluate-decoder --maps 0 --inlets 8 --samples 2048 --budget-min 40 ... --out ...'

A rebuilt line omits the values equal to the current defaults. Where a default has changed
since a result was written (or an option was added with a default other than what the result
was made with: :data:`VALUES_BEFORE`), the line names the recorded value right after the
command's name, so that it still reproduces the result: the decoder's ``--boundary`` became
``blend`` on 2026-12-06, and a result made with one pass rebuilds with ``--boundary average``.
A result made with the default decoder (no ``--model``) records, since 2026-12-06 (the
forty-seventh session), the SHA-256 of the file it read (``model_files``); where the shipped
model has been replaced since, the rebuilt line names the dated file kept of the one the result
was made with (``--model src/windnav/predict/data/decoder_<label>.npz``), and a model no longer
installed is an error naming its hash; so does a ``--model`` or ``--compare`` that names the
shipped file by its path, and (since the fifty-second session) a ``--decoder`` of
``benchmark-nav`` or ``nav-study`` and a ``--compare`` of ``nav-study inflight`` that does.
Results written before then record no hash, and their line names no model: they ran with the
default of their day, which ``docs/decoder.md`` and
``docs/benchmarks.md`` name (by date) beside each.
A test rebuilds every committed result and parses it back to its own arguments. Some commands
record a value they filled in themselves (``fly``'s ``--wind-sigma`` under ``--wind
constant``), which the rebuilt line then gives and the command may refuse; the typed ``argv``
has no such gap.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
from collections.abc import Mapping
from pathlib import Path

__all__ = ["command_line", "command_arguments", "VALUES_BEFORE", "MODEL_COMMANDS"]

VALUES_BEFORE = {
    "evaluate-decoder": {"boundary": "average", "compare_boundary": "average", "maps": 3,
                         "windinet": True},
    "predict": {"boundary": "average"},
    "decoder-study": {"boundary": "average"},
}
"""Per command, options a result may not record because they came later, with the value it
was made with: the decoder's rule at the sector boundaries. ``--boundary`` came to
``evaluate-decoder`` and ``predict`` on 2026-12-05 and to ``decoder-study`` on 2026-12-06, and
``--compare-boundary`` on 2026-12-06, when ``blend`` became the default; before, the decoders
took one pass (``average``; the side rounding picked until 2026-12-05, the same answer for every
inlet off a multiple of 45 deg, where no random evaluation inlet falls). ``evaluate-decoder``'s
``--maps`` (3) and ``--windinet`` (yes) default to None since the fiftieth session (2026-12-07),
resolved by the command (0 and no with ``--map``); the results before recorded the values, so
their rebuilt lines name them (``--windinet``, ``--maps 3``: what the line without them does
again, as long as it gives no ``--map``)."""


MODEL_COMMANDS = ("evaluate-decoder", "decoder-study", "predict", "navigate", "demo")
"""The commands whose ``--model`` defaults to the shipped decoder, which changes with each
model shipped: their results record the file's hash (``model_files``; ``navigate`` since
2026-12-07, for the onboard stack's variant only; ``demo`` since the fifty-fourth session, for
its ``--variant`` labels of the onboard stack)."""


def _load(doc) -> Mapping:
    """The document ``doc``, or the one its ``.json`` / ``.json.gz`` file holds; a ValueError
    naming 'doc' for anything else (None met pathlib's TypeError, a file of no JSON a
    JSONDecodeError, a bad .json.gz a BadGzipFile and a JSON list an AttributeError: Python
    API audit, fifty-eighth session)."""
    import gzip

    where = "command_line"
    if isinstance(doc, Mapping):
        return doc
    if not isinstance(doc, str | os.PathLike) or not str(doc):
        raise ValueError(f"The 'doc' parameter of {where} must be a result document (a dict) "
                         f"or the path of its .json or .json.gz file. Got {doc!r} instead.")
    path = Path(doc)
    try:
        if path.suffix == ".gz":
            with gzip.open(path, "rt") as f:
                loaded = json.load(f)
        else:
            loaded = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError, EOFError) as exc:  # BadGzipFile: OSError
        raise ValueError(f"The 'doc' parameter of {where} must name a readable JSON result "
                         f"file. Got {str(path)!r} instead ({type(exc).__name__}: {exc}).") \
            from exc
    if not isinstance(loaded, Mapping):
        raise ValueError(f"The 'doc' parameter of {where} must name a JSON result document (an "
                         f"object). Got {str(path)!r} instead, which holds a "
                         f"{type(loaded).__name__}.")
    return loaded


def _words(value) -> list[str]:
    values = value if isinstance(value, list | tuple) else [value]
    return [v if isinstance(v, str) else json.dumps(v) if isinstance(v, bool) else str(v)
            for v in values]


def _same(value, default) -> bool:
    """``value`` (as JSON recorded it) equals the parser's ``default``."""
    try:
        return json.loads(json.dumps(default, default=str)) == value
    except (TypeError, ValueError):
        return False


def _flag(action: argparse.Action, value, check_default: bool = True) -> list[str] | None:
    """The words that give ``action`` the value ``value``, or None where none are needed
    (``check_default``: none for the parser's default)."""
    if value is None or (check_default and _same(value, action.default)):
        return None  # unset, or the default's
    longest = max(action.option_strings, key=len)
    if isinstance(action, argparse.BooleanOptionalAction):
        positive = [s for s in action.option_strings if not s.startswith("--no-")]
        negative = [s for s in action.option_strings if s.startswith("--no-")]
        return [max(positive, key=len) if value else max(negative, key=len)]
    if isinstance(action, argparse._StoreTrueAction | argparse._StoreFalseAction):
        return [longest] if value != action.default else None
    if isinstance(action, argparse._StoreConstAction):
        return [longest] if value == action.const else None
    if isinstance(action, argparse._CountAction):
        return [longest] * int(value) if value else None
    if isinstance(action, argparse._AppendAction):
        out = []
        for item in value:
            out += [longest, *_words(item)]
        return out or None
    if isinstance(value, list | tuple) and not value and action.nargs in ("*", "?"):
        return [longest]
    return [longest, *_words(value)]


def command_arguments(doc) -> list[str]:
    """``["windnav", NAME, ...]``: the words of :func:`command_line` (a document, or the path
    of a ``.json`` or ``.json.gz`` file)."""
    from windnav.cli import build_parser
    from windnav.experiments.results import NOT_ARGUMENTS

    doc = _load(doc)
    command, recorded = doc.get("command"), doc.get("arguments")
    where = "command_line"
    if not isinstance(command, str) or not command.startswith("windnav "):
        raise ValueError(f"The 'doc' parameter of {where} must be a windnav result document "
                         f"that records its 'command'. Got command={command!r} instead.")
    if not isinstance(recorded, Mapping):
        raise ValueError(f"The 'doc' parameter of {where} must record its 'arguments' (a "
                         f"result of {command!r} written without them cannot be rebuilt).")
    root = build_parser()
    name = command.split()[1]
    if name not in root.commands:
        raise ValueError(f"{where}: the command {name!r} that wrote this result is no longer a "
                         "windnav command.")
    argv = doc.get("argv")
    if isinstance(argv, list) and argv and all(isinstance(w, str) for w in argv):
        # an argv without the command's name (['--nope']) gave "windnav --nope" (Python API
        # audit, fifty-eighth session)
        if argv[0] != name:
            raise ValueError(f"The 'doc' parameter of {where} must record argv starting with "
                             f"its command's name {name!r}. Got argv {argv!r} instead.")
        return _parsed(_replaced_models(_changed_defaults(["windnav", *argv], root, name,
                                                          recorded), root, name, doc),
                       root, name)
    words = ["windnav", name]
    parser = root.commands[name]
    left = {k: v for k, v in recorded.items() if k not in NOT_ARGUMENTS}
    positionals: list[str] = []
    while True:
        sub = None
        options: list[str] = []
        for action in parser._actions:
            if isinstance(action, argparse._HelpAction | argparse._VersionAction):
                continue
            if isinstance(action, argparse._SubParsersAction):
                sub = action
                continue
            if action.dest not in left:
                continue
            value = left.pop(action.dest)
            if not action.option_strings:
                positionals += _words(value) if value is not None else []
                continue
            flag = _flag(action, value)
            if flag:
                options += flag
        words += positionals + options
        positionals = []
        if sub is None or sub.dest not in left:
            break
        chosen = left.pop(sub.dest)
        if chosen not in sub.choices:
            raise ValueError(f"{where}: {name!r} has no {sub.dest} {chosen!r} any more.")
        words.append(chosen)
        parser = sub.choices[chosen]
    unknown = sorted(k for k, v in left.items() if v is not None)
    if unknown:
        raise ValueError(f"{where}: the result records arguments that 'windnav {name}' no "
                         f"longer has: {', '.join(unknown)}; the line it was written by cannot "
                         "be rebuilt with this version.")
    return _parsed(_replaced_models(_changed_defaults(words, root, name, recorded), root,
                                    name, doc), root, name)


def _parsed(words: list[str], parser, name: str) -> list[str]:
    """``words``, once the current interface parses them: a recorded value it refuses
    (``--duration abc``) gave a line that did not run (Python API audit, fifty-eighth
    session); now a ValueError (:func:`_parse`)."""
    _parse(parser, words, name)
    return words


def _shown(path: Path) -> str:
    """``path`` relative to the working folder where it lies under it (a checkout's
    ``src/windnav/...``), else absolute."""
    try:
        return str(path.resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path.resolve())


def _replaced_models(words: list[str], parser, name: str, doc: Mapping) -> list[str]:
    """``words`` naming, for each decoder the result read from the shipped file (by default or
    by that file's path, ``--model``, a ``--compare`` item, or ``--decoder``) whose recorded
    SHA-256 is no longer the shipped file's, the dated file with that hash: ``--model FILE``
    inserted after the command's name where the words name no model, the path replaced where
    they name the shipped file. A hash no installed file has is a ValueError naming it. The
    files read: ``model_files`` (:data:`MODEL_COMMANDS`, and ``nav-study inflight``'s
    ``--compare`` since the fifty-second session) and ``decoder_file`` (``benchmark-nav`` and
    ``nav-study``'s ``--decoder``, recorded since the fiftieth session)."""
    files = doc.get("model_files")
    files = files if isinstance(files, Mapping) else {}
    decoder = doc.get("decoder_file")
    decoder = decoder if isinstance(decoder, Mapping) else None
    if not files and decoder is None:
        return words
    from windnav.predict.decoder import DEFAULT_MODEL

    words = _unabbreviated(words, parser.commands[name], ("--model", "--compare", "--decoder"))
    made = files.get("model") if name in MODEL_COMMANDS else None
    compare = files.get("compare")
    recorded = [("--model", made.get("path"), made)] if isinstance(made, Mapping) else []
    if isinstance(compare, Mapping):
        recorded += [("--compare", text, rec) for text, rec in compare.items()]
    if decoder is not None:
        recorded.append(("--decoder", decoder.get("path"), decoder))
    swaps: dict[tuple[str, str], str] = {}
    insert = None
    for option, text, rec in recorded:
        sha = rec.get("sha256") if isinstance(rec, Mapping) else None
        if not isinstance(text, str) or not isinstance(sha, str) or not sha:
            continue
        # [NAME=]FILE split at the first "=", as the commands read it
        label, file = text.split("=", 1) if option == "--compare" and "=" in text else ("", text)
        if text == "default" and option == "--model":
            if _parse(parser, words, name).get("model") is None:
                dated = _dated_default(sha)
                insert = None if dated is None else _shown(dated)
        elif _names_shipped_file(file, DEFAULT_MODEL):
            try:
                dated = _dated_default(sha)
            except ValueError:  # another checkout's file of that name: its own model
                if Path(file).resolve() == DEFAULT_MODEL:
                    raise
                dated = None
            if dated is not None:
                swaps[option, text] = (f"{label}=" if label else "") + _shown(dated)

    def key(option: str, value: str) -> tuple[str, str]:  # a file option's path as recorded
        return option, (str(Path(value)) if option in ("--model", "--decoder") and value
                        else value)

    out = []
    for i, word in enumerate(words):
        option, eq, value = word.partition("=")
        if eq and key(option, value) in swaps:
            word = f"{option}={swaps[key(option, value)]}"
        elif i and key(words[i - 1], word) in swaps:
            word = swaps[key(words[i - 1], word)]
        out.append(word)
    return out[:2] + ["--model", insert] + out[2:] if insert else out


def _unabbreviated(words: list[str], parser, flags: tuple[str, ...]) -> list[str]:
    """``words`` with each abbreviation of one of ``flags`` (a prefix that argparse would read
    as it: no other option of ``parser`` starts with it) written out in full, so that a typed
    ``--mod FILE`` is found as ``--model FILE``."""
    if not parser.allow_abbrev:
        return words
    strings = [s for a in parser._actions for s in a.option_strings if s.startswith("--")]
    out = []
    for word in words:
        flag, eq, value = word.partition("=")
        if flag.startswith("--") and len(flag) > 2 and flag not in strings:
            found = [s for s in strings if s.startswith(flag)]
            if len(found) == 1 and found[0] in flags:
                word = found[0] + eq + value
        out.append(word)
    return out


def _names_shipped_file(file: str, shipped: Path) -> bool:
    """Whether a recorded path names the shipped decoder's file ``shipped`` (resolved from
    here, or as the path of a checkout's ``src/windnav/predict/data/decoder_default.npz``
    written from elsewhere)."""
    path = Path(file.replace("\\", "/"))  # a path written on Windows
    return path.resolve() == shipped or path.parts[-4:] == shipped.parts[-4:]


def _dated_default(sha: str) -> Path | None:
    """None where ``sha`` is the shipped decoder file's SHA-256, else the installed dated file
    with that hash (a model the shipped one replaced); a ValueError names a hash no installed
    file has."""
    from windnav.predict.decoder import DEFAULT_MODEL, model_sha256, shipped_model_file

    if DEFAULT_MODEL.is_file() and model_sha256() == sha:
        return None
    file = shipped_model_file(sha)
    if file is None:
        raise ValueError(f"command_line: the result was made with the default decoder of its "
                         f"day (SHA-256 {sha}), which this windnav no longer installs (not "
                         f"{str(DEFAULT_MODEL)!r} nor a dated file beside it); its line cannot "
                         "name the model that made it.")
    return file


def _changed_defaults(words: list[str], parser, name: str, recorded: Mapping) -> list[str]:
    """``words`` with the options of :data:`VALUES_BEFORE` (a default changed since) whose
    value the words now parse to differs from the one the result was made with (recorded, else
    the value before), inserted after the command's name (so that no ``--`` or option of
    several values in the typed words swallows them). Only those: some commands record values
    they filled in themselves, which the typed line rightly leaves out. ``compare_boundary``
    counts by its effect: unset, the compared models take ``--boundary``'s rule, and a result
    without compared models needs none."""
    if name not in parser.commands or name not in VALUES_BEFORE:
        return words
    parsed = _parse(parser, words, name)
    made = {k: recorded.get(k, v) for k, v in VALUES_BEFORE[name].items()}
    if "compare_boundary" in made:
        if not recorded.get("compare"):
            made.pop("compare_boundary")
        elif made["compare_boundary"] is None:  # they followed the decoder's rule
            made["compare_boundary"] = made.get("boundary", parsed.get("boundary"))
    actions = {a.dest: a for a in _actions(parser.commands[name])}
    extra: list[str] = []
    for dest, value in made.items():
        action = actions.get(dest)
        now = parsed.get(dest)
        if dest == "compare_boundary" and now is None:
            now = made.get("boundary", parsed.get("boundary"))
        if action is None or not action.option_strings or _same(value, now):
            continue
        extra += _flag(action, value, check_default=False) or []
    return words[:2] + extra + words[2:]


def _parse(parser, words: list[str], name: str) -> dict:
    """The arguments ``words`` parse to, or a ValueError naming the line (argparse would exit)."""
    try:
        return vars(parser.parse_args(words[1:]))
    except SystemExit as exc:
        raise ValueError(f"command_line: the line of this result, {shlex.join(words)!r}, no "
                         f"longer parses with 'windnav {name}' (argparse's message above)."
                         ) from exc


def _actions(parser) -> list[argparse.Action]:
    """The actions of ``parser`` and of its subcommands' parsers."""
    out = []
    for action in parser._actions:
        out.append(action)
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                out += _actions(sub)
    return out


def command_line(doc) -> str:
    """The command line (one shell line) that wrote the result ``doc``: a document (dict)
    with ``command`` and ``arguments``, or the path of its ``.json`` / ``.json.gz`` file.

    Raises
    ------
    ValueError
        When ``doc`` is no document nor a readable JSON file of one; when the document records
        no command or arguments, or arguments the current command no longer has (named), or
        an ``argv`` that does not start with its command's name; or when the line does not
        parse with the current interface (argparse's message on stderr).
    """
    return shlex.join(command_arguments(doc))


def _main() -> None:  # pragma: no cover - python -m windnav.provenance FILE...
    import sys

    for path in sys.argv[1:]:
        print(f"{os.fspath(path)}: {command_line(path)}")


if __name__ == "__main__":  # pragma: no cover
    _main()
