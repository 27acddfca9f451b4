"""Every fenced code block of the README and the docs, run as a reader would run it.

A block is preceded by a marker, an HTML comment that the rendered page does not show:

    <!-- example: run -->            a `sh` or `python` block: run from the repository root, must succeed
    <!-- example: output -->         a `text` block: what the nearest `run` block above prints
    <!-- example: output
    command: CMD -->                 a `text` block: what CMD prints (the command the page describes in words)
    <!-- example: excerpt
    command: CMD -->                 a block quoted from what CMD writes (e.g. an exported file)
    <!-- example: doctest CRATE -->  a `rust` block compiled by `cargo test -p CRATE` (the crate includes the file)
    <!-- example: skip REASON -->    not run, for the reason given (e.g. the test suite itself)

Further lines of a marker, one each:
    sub: OLD => NEW                  run the block with OLD replaced by NEW: documented shortenings only
    same: COMMITTED = PRODUCED       after the run, a file the page shows equals the one just made, byte for byte
    fails: true                      the command must fail (an error message the page quotes)

In commands `$OUT` is a fresh temporary directory of the block's own. A printed block is compared
with whitespace runs collapsed; `…` stands for any text (wall times). So changing any number a
page shows as printed makes its block fail, and a block without a marker fails too.
"""

import os
import pathlib
import re
import subprocess
import sys

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]
PAGES = ["README.md", "fmi/README.md", *sorted(str(p.relative_to(REPO)) for p in (REPO / "docs").glob("*.md"))]
TARGET = os.environ.get("CARGO_TARGET_DIR", "target")
MARKER = re.compile(r"<!--\s*example:\s*(?P<body>.*?)-->", re.S)
FENCE = re.compile(r"^```")
KINDS = {"run", "output", "excerpt", "doctest", "skip"}


class Block:
    def __init__(self, page, line, lang, text, kind, arg, options):
        self.page, self.line, self.lang, self.text = page, line, lang, text
        self.kind, self.arg, self.options = kind, arg, options
        self.run = None  # for `output`: the `run` block it belongs to

    @property
    def id(self):
        return f"{self.page}:{self.line}"

    def values(self, key):
        return self.options.get(key, [])


def parse_marker(body):
    lines = [line.strip() for line in body.strip().splitlines() if line.strip()]
    head = lines[0].split(None, 1)
    kind, arg = head[0], (head[1] if len(head) > 1 else "")
    options = {}
    for line in lines[1:]:
        key, _, value = line.partition(":")
        options.setdefault(key.strip(), []).append(value.strip())
    return kind, arg, options


def blocks_of(page):
    """The page's fenced blocks with their markers (None where a block has none)."""
    lines = (REPO / page).read_text().splitlines()
    found, last_run, k = [], None, 0
    while k < len(lines):
        if not FENCE.match(lines[k].lstrip()):
            k += 1
            continue
        start, lang = k, lines[k].lstrip()[3:].strip()
        end = next(j for j in range(k + 1, len(lines)) if FENCE.match(lines[j].lstrip()))
        text = "\n".join(lines[start + 1 : end])
        before = "\n".join(lines[:start]).rstrip()
        markers = list(MARKER.finditer(before))
        if markers and markers[-1].end() == len(before):
            block = Block(page, start + 1, lang, text, *parse_marker(markers[-1].group("body")))
        else:
            block = Block(page, start + 1, lang, text, None, "", {})
        if block.kind == "run":
            last_run = block
        if block.kind == "output" and "command" not in block.options:
            block.run = last_run
        found.append(block)
        k = end + 1
    return found


BLOCKS = [b for page in PAGES for b in blocks_of(page)]


def expand(command, out):
    """The command as run here: `$OUT`, and the build directory where CARGO_TARGET_DIR moves it."""
    command = command.replace("$OUT", str(out))
    if TARGET != "target":
        command = command.replace("target/release/", f"{TARGET}/release/")
    return command


def substituted(block):
    text = block.text
    for sub in block.values("sub"):
        old, sep, new = sub.partition(" => ")
        assert sep, f"{block.id}: `sub: {sub}` needs the form `OLD => NEW`"
        assert old in text, f"{block.id}: `sub: {sub}`: `{old}` is not in the block"
        text = text.replace(old, new)
    return text


def execute(block, tmp_path, command=None, lang=None):
    """Runs the block (or a marker's command) from the repository root: (exit code, stdout + stderr)."""
    lang = lang or block.lang
    code = expand(command if command is not None else substituted(block), tmp_path)
    if lang == "python":
        argv = [sys.executable, "-c", code]
    elif lang in ("sh", "bash", ""):
        argv = ["bash", "-euo", "pipefail", "-c", code]
    else:
        pytest.fail(f"{block.id}: cannot run a `{lang}` block")
    env = dict(os.environ, OUT=str(tmp_path))
    done = subprocess.run(argv, cwd=REPO, env=env, capture_output=True, text=True, timeout=600)
    return done.returncode, done.stdout + done.stderr


def normalized(text):
    return " ".join(text.split())


def shows(expected, printed):
    """Whether `printed` contains `expected`, whitespace runs collapsed, `…` matching any text."""
    parts = [re.escape(normalized(p)) for p in expected.split("…")]
    return re.search(r".*?".join(parts), normalized(printed), re.S) is not None


_runs = {}


def run_once(block, tmp_path_factory):
    """A `run` block's result, run once per session (its output blocks share it)."""
    if block.id not in _runs:
        out = tmp_path_factory.mktemp("example")
        code, printed = execute(block, out)
        _runs[block.id] = (code, printed, out)
    return _runs[block.id]


def test_every_block_has_a_marker():
    unmarked = [b.id for b in BLOCKS if b.kind is None]
    unknown = [f"{b.id} ({b.kind})" for b in BLOCKS if b.kind is not None and b.kind not in KINDS]
    assert not unmarked, f"fenced blocks without an `<!-- example: ... -->` marker: {unmarked}"
    assert not unknown, f"unknown example kinds: {unknown}"
    assert all(b.arg for b in BLOCKS if b.kind in ("skip", "doctest")), "a skip gives its reason, a doctest its crate"


def test_the_markers_are_read():
    """The parser itself: a page with every kind of block."""
    assert shows("a 1 … c 3", "x\na  1 b 2 c 3\n")
    assert not shows("a 1 … c 4", "a 1 b 2 c 3")
    kinds = {b.kind for b in BLOCKS}
    assert {"run", "output", "skip", "excerpt", "doctest"} <= kinds, kinds
    assert all(b.run is not None for b in BLOCKS if b.kind == "output" and "command" not in b.options)


@pytest.mark.parametrize("block", [b for b in BLOCKS if b.kind == "run"], ids=lambda b: b.id)
def test_run_block(block, tmp_path_factory):
    code, printed, out = run_once(block, tmp_path_factory)
    assert code == 0, f"{block.id} exited with {code}:\n{printed[-4000:]}"
    for pair in block.values("same"):
        committed, sep, produced = pair.partition(" = ")
        assert sep, f"{block.id}: `same: {pair}` needs the form `COMMITTED = PRODUCED`"
        a, b = REPO / committed, pathlib.Path(expand(produced, out))
        if not b.is_absolute():
            b = REPO / b
        assert a.read_bytes() == b.read_bytes(), f"{block.id}: {committed} differs from what the command made ({b})"


@pytest.mark.parametrize("block", [b for b in BLOCKS if b.kind in ("output", "excerpt")], ids=lambda b: b.id)
def test_printed_block(block, tmp_path_factory):
    if "command" in block.options:
        out = tmp_path_factory.mktemp("example")
        code, printed = execute(block, out, command=block.values("command")[0], lang="sh")
        failing = block.values("fails") == ["true"]
        assert (code != 0) == failing, f"{block.id}: exit code {code}:\n{printed[-4000:]}"
    else:
        code, printed, _ = run_once(block.run, tmp_path_factory)
        assert code == 0, f"{block.id}: its command ({block.run.id}) exited with {code}:\n{printed[-4000:]}"
    assert shows(block.text, printed), f"{block.id} shows\n{block.text}\nbut the command printed\n{printed[-4000:]}"


@pytest.mark.parametrize("block", [b for b in BLOCKS if b.kind == "doctest"], ids=lambda b: b.id)
def test_doctest_block_is_included(block):
    """A doctest block runs in `cargo test` only if its crate includes the page."""
    lib = REPO / block.arg / "src" / "lib.rs"
    page = os.path.relpath(REPO / block.page, lib.parent)
    assert f'include_str!("{page}")' in lib.read_text(), f"{lib} does not include {block.page} as doctests"
