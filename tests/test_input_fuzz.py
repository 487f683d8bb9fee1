"""Property: whatever scenario file, command line or BVH clip a user gives, the run exits 0 or 2,
and on 2 prints exactly one line on stderr -- never a traceback (issue 10).

Inputs are the project's own scenarios, fully resolved (every key written out, so mutations
reach every section at every depth), then mutated: wrong types, out-of-range and non-finite
numbers, unknown and misspelled keys at any depth, lists where mappings belong and back,
deleted keys; or replaced by empty, truncated, non-UTF-8 or binary files; plus ``--set``,
``--duration``, ``--seed``, ``--rerun`` and unknown options on the command line. Most examples
run ``python -m humimic.run``'s ``main`` in-process with ``--dry-run`` stopped before the world
is built (loading and validation are what bad input reaches first); a few build the world too
(``--dry-run`` as is), and malformed BVH clips go through the parser and the retargeting.

Examples: ``HUMIMIC_FUZZ_EXAMPLES`` (default 300) for the scenario/command-line property, a
third of that for BVH clips, a sixtieth (at least 5) for world-building dry runs; the examples
are derandomized (the same every run) unless ``HUMIMIC_FUZZ_RANDOM=1``.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
from pathlib import Path
from unittest import mock

import yaml
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from humimic import run
from humimic.errors import InputError
from humimic.motion.config import BVHMotion
from humimic.motion.context import MotionContext
from humimic.motion.factory import make_trajectory
from humimic.paths import DATA_DIR, SCENARIOS_DIR
from humimic.scenario import dump_scenario, load_scenario

N_EXAMPLES = int(os.environ.get("HUMIMIC_FUZZ_EXAMPLES", "300"))
FUZZ = settings(deadline=None, database=None, print_blob=True,
                derandomize=not os.environ.get("HUMIMIC_FUZZ_RANDOM"),
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                       HealthCheck.function_scoped_fixture,
                                       HealthCheck.large_base_example])

SCENARIO_FILES = sorted(SCENARIOS_DIR.glob("*.yaml"))
#: Every scenario fully resolved (absolute paths, every default), as a YAML mapping.
RESOLVED = {p.stem: yaml.safe_load(dump_scenario(load_scenario(p))) for p in SCENARIO_FILES}
#: The same scenarios as written (relative paths: from another directory some break, which is
#: bad input too).
WRITTEN = {p.stem: yaml.safe_load(p.read_text()) for p in SCENARIO_FILES}
#: Scenarios cheap to build for the world-building dry runs (no colour-model learning).
CHEAP = ["static", "wave", "figure8", "head_sweep", "mimic_wave", "bvh_cmu", "wearable_jump",
         "keyframes", "ude_wave_tracking"]

junk_scalar = st.one_of(
    st.none(), st.booleans(), st.integers(-10**12, 10**12),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, -1, 1, 1e9, -1e-9, 0.5, 2, "", "nan", ".inf", "1e999", "yes", "~"]),
    st.text(max_size=12))
junk = st.recursive(junk_scalar, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=8), inner, max_size=3)),
    max_leaves=6)


def _paths(node, prefix=()) -> list[tuple]:
    """Every path into a YAML tree (mapping keys and list indices)."""
    out = [prefix]
    if isinstance(node, dict):
        for k, v in node.items():
            out += _paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += _paths(v, prefix + (i,))
    return out


def _get(node, path):
    for p in path:
        node = node[p]
    return node


def _typo(draw, word: str) -> str:
    if not word:
        return draw(st.text(min_size=1, max_size=8))
    i = draw(st.integers(0, len(word) - 1))
    how = draw(st.sampled_from(["drop", "swap", "add", "case"]))
    if how == "drop":
        return word[:i] + word[i + 1:] or "x"
    if how == "swap" and i + 1 < len(word):
        return word[:i] + word[i + 1] + word[i] + word[i + 2:]
    if how == "case":
        return word.upper() if word != word.upper() else word + "_"
    return word[:i] + draw(st.sampled_from("aeiorstx_")) + word[i:]


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _perturb(draw, doc: dict) -> None:
    """Scale or shift one number of ``doc``: mostly still valid, often at odd values."""
    paths = [p for p in _paths(doc) if p and _is_number(_get(doc, p))]
    if paths:
        path = draw(st.sampled_from(paths))
        x = _get(doc, path)
        y = draw(st.sampled_from([0, -x, 0.5 * x, 2 * x, 10 * x, 1e-3 * x, x + 1, x - 1, 1e-6]))
        _get(doc, path[:-1])[path[-1]] = type(x)(y) if isinstance(x, int) else y


def _mutate(draw, doc: dict) -> None:
    """One random edit of ``doc`` in place."""
    path = draw(st.sampled_from(_paths(doc)))
    node = _get(doc, path)
    parent = _get(doc, path[:-1]) if path else None
    how = draw(st.sampled_from(["value", "value", "unknown_key", "typo_key", "as_list",
                                "as_mapping", "delete", "perturb", "perturb"]))
    if how == "perturb":
        _perturb(draw, doc)
    elif how == "value" and path:
        parent[path[-1]] = draw(junk)
    elif how in ("unknown_key", "typo_key") and isinstance(node, dict):
        keys = [k for k in node if isinstance(k, str)]
        key = (_typo(draw, draw(st.sampled_from(keys))) if how == "typo_key" and keys
               else draw(st.text(min_size=1, max_size=10)))
        node[key] = draw(junk)
    elif how == "as_list" and path and isinstance(node, dict):
        parent[path[-1]] = list(node.values()) if draw(st.booleans()) else list(node)
    elif how == "as_mapping" and path and isinstance(node, list):
        parent[path[-1]] = {str(i): v for i, v in enumerate(node)}
    elif how == "delete" and path and isinstance(parent, dict):
        del parent[path[-1]]


@st.composite
def scenario_bytes(draw, base: dict, mostly_valid: bool = False) -> bytes:
    """A scenario file: ``base`` mutated, or broken at the byte level; ``mostly_valid``: one or
    two numbers perturbed, the file intact (to reach the world's construction)."""
    doc = json.loads(json.dumps(base))  # a deep copy (YAML trees here are JSON-like)
    if mostly_valid:
        for _ in range(draw(st.integers(1, 2))):
            _perturb(draw, doc)
        return yaml.safe_dump(doc, sort_keys=False).encode()
    for _ in range(draw(st.integers(0, 3))):
        _mutate(draw, doc)
    text = yaml.safe_dump(doc, sort_keys=False).encode()
    form = draw(st.sampled_from(["yaml"] * 6 + ["empty", "comment", "truncated", "non_utf8",
                                                "binary", "scalar", "list"]))
    if form == "empty":
        return b""
    if form == "comment":
        return b"# nothing here\n\n"
    if form == "truncated":
        return text[:draw(st.integers(0, len(text)))]
    if form == "non_utf8":
        i = draw(st.integers(0, len(text)))
        return text[:i] + draw(st.binary(min_size=1, max_size=3).map(
            lambda b: bytes(0x80 | c for c in b))) + text[i:]
    if form == "binary":
        return draw(st.binary(max_size=64))
    if form == "scalar":
        return draw(st.sampled_from([b"42\n", b"just text\n", b"~\n", b"[]\n"]))
    if form == "list":
        return yaml.safe_dump(list(doc.items())[:3]).encode()
    return text


@st.composite
def command_line(draw, doc: dict) -> list[str]:
    """Options after the scenario path: ``--set`` of real, misspelled or made-up keys to junk
    values, and bad ``--duration``/``--seed``/``--rerun``/unknown options."""
    args: list[str] = []
    for _ in range(draw(st.integers(0, 2))):
        path = [str(p) for p in draw(st.sampled_from(_paths(doc)[1:] or [("name",)]))]
        key_form = draw(st.sampled_from(["real", "real", "typo", "deeper", "index", "text"]))
        if key_form == "typo":
            path[-1] = _typo(draw, path[-1])
        elif key_form == "deeper":
            path.append(draw(st.sampled_from(["x", "0", "kind", "5"])))
        elif key_form == "index":
            path.append(str(draw(st.integers(0, 9))))
        elif key_form == "text":
            path = [draw(st.text(max_size=10))]
        value = draw(st.one_of(junk.map(lambda v: json.dumps(v, allow_nan=True)),
                               st.text(max_size=10)))
        args += ["--set", f"{'.'.join(path)}={value}"]
    for option in ("--duration", "--seed"):
        if draw(st.integers(0, 5)) == 0:
            args += [option, draw(st.one_of(
                st.sampled_from(["0", "-1", "1e9", "nan", "inf", "soon", "0.1", ""]),
                st.integers(-5, 10**6).map(str), st.floats().map(str)))]
    if draw(st.integers(0, 9)) == 0:
        args += draw(st.sampled_from([["--rerun", "maybe"], ["--frobnicate"], ["--seed"],
                                      ["--out", "/dev/null"]]))
    return args


def _main(argv: list[str]) -> tuple[int, str]:
    """``python -m humimic.run`` in-process: exit code and stderr."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = run.main(argv)
        except SystemExit as exc:  # argparse's usage errors
            code = exc.code
    return code, err.getvalue()


def _check(code, err: str, argv) -> None:
    event(f"exit {code}")
    assert "Traceback" not in err, (argv, err)
    assert code in (0, 2), (argv, code, err)
    if code == 2:
        lines = err.strip("\n").split("\n")
        assert len(lines) == 1 and lines[0].startswith("error: "), (argv, err)


def _write(tmp: Path, data: bytes) -> Path:
    path = tmp / "fuzz.yaml"
    path.write_bytes(data)
    return path


@st.composite
def _case(draw, names=None):
    written = draw(st.integers(0, 4)) == 0
    name = draw(st.sampled_from(names or sorted(RESOLVED)))
    base = (WRITTEN if written and names is None else RESOLVED)[name]
    if names is not None:
        return draw(scenario_bytes(base, mostly_valid=True)), []
    return draw(scenario_bytes(base)), draw(command_line(base))


@settings(FUZZ, max_examples=N_EXAMPLES)
@given(case=_case())
def test_scenarios_and_command_lines_exit_0_or_2_with_one_line(tmp_path_factory, case):
    data, options = case
    path = _write(tmp_path_factory.mktemp("fuzz"), data)
    argv = [str(path), "--quiet", "--dry-run", *options]
    with mock.patch.object(run, "dry_run", lambda scenario: None):  # validation only
        code, err = _main(argv)
    _check(code, err, argv)
    if code == 0 and "--dry-run" in argv:
        assert err == ""


@settings(FUZZ, max_examples=max(5, N_EXAMPLES // 60))
@given(case=_case(CHEAP))
def test_world_building_dry_runs_exit_0_or_2_with_one_line(tmp_path_factory, case):
    data, options = case
    path = _write(tmp_path_factory.mktemp("fuzz"), data)
    argv = [str(path), "--quiet", "--dry-run", *options, "--duration", "0.2"]  # last one wins
    _check(*_main(argv), argv)


CLIP = (DATA_DIR / "mocap" / "cmu_01_01.bvh").read_text().splitlines()
_M = CLIP.index("MOTION")
#: A short valid clip: the hierarchy and 30 frames.
SHORT_CLIP = CLIP[:_M + 1] + ["Frames: 30", CLIP[_M + 2]] + CLIP[_M + 3:_M + 33]
CONTEXT = MotionContext.facing_robot(duration=0.3)


@st.composite
def bvh_bytes(draw) -> bytes:
    lines = list(SHORT_CLIP)
    for _ in range(draw(st.integers(1, 3))):
        if len(lines) < _M + 3:  # cut before the motion header: nothing more to edit
            break
        i = draw(st.integers(0, len(lines) - 1))
        how = draw(st.sampled_from(["drop", "dup", "token", "frames", "frame_time", "cut",
                                    "binary", "values"]))
        if how == "drop":
            del lines[i]
        elif how == "dup":
            lines.insert(i, lines[i])
        elif how == "token":
            words = lines[i].split() or [""]
            words[draw(st.integers(0, len(words) - 1))] = draw(st.one_of(
                st.sampled_from(["nan", "inf", "-1", "0", "{", "}", "JOINT", "1e999", "99"]),
                st.text(max_size=6)))
            lines[i] = " ".join(words)
        elif how == "frames":
            lines[_M + 1] = "Frames: " + draw(st.sampled_from(
                ["0", "1", "2", "29", "31", "1000000000", "-3", "x", "２", "³"]))
        elif how == "frame_time":
            lines[_M + 2] = "Frame Time: " + draw(st.sampled_from(
                ["0", "-0.1", "1", "10", "1e-9", "1e300", "nan", "inf", "x"]))
        elif how == "cut":
            lines = lines[:i]
            break
        elif how == "values":
            k = draw(st.integers(_M + 3, len(SHORT_CLIP) - 1))
            if k < len(lines):
                lines[k] = " ".join(str(draw(st.floats(-1e6, 1e6))) for _ in lines[k].split())
    data = "\n".join(lines).encode()
    if draw(st.integers(0, 7)) == 0:
        i = draw(st.integers(0, len(data)))
        data = data[:i] + b"\xff\xfe\x81" + data[i:]
    return data


@settings(FUZZ, max_examples=max(20, N_EXAMPLES // 3))
@given(data=bvh_bytes(), start=st.sampled_from([0.0, 0.1, 1.0]),
       smoothing=st.sampled_from([6.0, None, 100.0]))
def test_malformed_bvh_raises_only_input_errors(tmp_path_factory, data, start, smoothing):
    clip = tmp_path_factory.mktemp("bvh") / "clip.bvh"
    clip.write_bytes(data)
    cfg = BVHMotion(kind="bvh", file=clip, start=start, smoothing=smoothing)
    try:
        make_trajectory(cfg, CONTEXT)
        event("played")
    except InputError as err:
        event("InputError")
        assert "\n" not in str(err)
