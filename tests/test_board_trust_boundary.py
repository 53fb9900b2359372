"""An outside review of the board's trust boundary (2026-11-29), as classes of attack: a
`.npy` header that lies about the data behind it (in an action table and in each member of
an exported policy), an action table or policy with a value that is not finite, names
that are not printable text (a newline forges a line of the listing), run and method
folders that are symbolic links, seed numbers in digits other than ASCII's, and a gait
shipped through a link. Each is refused or listed in one line, and none raises.
"""

import csv
import io
import json
import os
import shutil
import zipfile

import numpy as np
import pytest

from analysis import leaderboard
from cpg_suite.protocol import admission, copies, verify
from cpg_suite.protocol import files as files_module
from cpg_suite.runfiles import exported

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RUNS = os.path.join(ROOT, "results", "protocol", "runs")
GAIT_RUN = os.path.join(RUNS, "cem", "darwin_walk", "K50_n0.8_e2_seed0")
PPO_RUN = os.path.join(RUNS, "ppo", "darwin_walk", "joints_seed0")
STEPS = 1000  # the shipped runs' trial_steps


def _header(descr, shape, fortran_order=False, version=(1, 0)) -> bytes:
    buf = io.BytesIO()
    header = {"descr": descr, "fortran_order": fortran_order, "shape": shape}
    if version == (1, 0):
        np.lib.format.write_array_header_1_0(buf, header)
    else:
        np.lib.format.write_array_header_2_0(buf, header)
    return buf.getvalue()


def _npy(array: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, array, allow_pickle=True)
    return buf.getvalue()


# Each lie: (a valid array) -> the bytes of a `.npy` file that is not that array, honestly.
LIES = {
    "huge shape, tiny data": lambda a: _header("<f8", (4_000_000_000,)) + b"\0" * 64,
    "huge shape, format 2.0": lambda a: _header("<f8", (2**40,), version=(2, 0)) + b"\0" * 64,
    "one value more than the data": lambda a: _header("<f8", (a.size + 1,)) + a.tobytes(),
    "more data than the shape": lambda a: _npy(a) + b"\0" * 8,
    "truncated data": lambda a: _npy(a)[:-8],
    "truncated header": lambda a: _npy(a)[:20],
    "pickled objects": lambda a: _npy(np.array([{"w": 1.0}], dtype=object)),
    "huge text items": lambda a: _header("<U1000000000", (1,)) + b"\0" * 64,
    "empty text items": lambda a: _header("<U0", (8,)),
    "records": lambda a: _header([("w", "<f8")], (a.size,)) + a.tobytes(),
    "complex numbers": lambda a: _header("<c16", (a.size // 2,)) + a.tobytes(),
    "format 3.0": lambda a: np.lib.format.magic(3, 0) + _npy(a)[8:],
    "not a header": lambda a: np.lib.format.magic(1, 0) + b"\x10\x00" + b"{not python}" + b" " * 4,
    "not npy at all": lambda a: b"PK\x03\x04 this is no array",
}


@pytest.mark.parametrize("lie", sorted(LIES))
def test_a_lying_npy_header_is_refused_in_one_line_before_anything_is_allocated(tmp_path, lie):
    array = np.arange(24, dtype=np.float64) / 100
    path = tmp_path / "a.npy"
    path.write_bytes(LIES[lie](array))
    with pytest.raises(ValueError) as error:
        exported.load_npy(str(path))
    assert "\n" not in str(error.value) and str(error.value).startswith("a.npy")


@pytest.mark.parametrize(
    "array",
    [
        np.asfortranarray(np.arange(24, dtype=np.float64).reshape(4, 6)),
        np.arange(24, dtype=">f8").reshape(2, 3, 4),
        np.array("swish"),
        np.float64(0.25),
        np.zeros((0, 12)),
        np.array([True, False]),
    ],
    ids=["fortran order", "big-endian", "text", "scalar", "empty", "booleans"],
)
def test_an_honest_npy_reads_as_numpy_reads_it(tmp_path, array):
    path = tmp_path / "a.npy"
    np.save(path, array)
    mine, numpy_s = exported.load_npy(str(path)), np.load(path, allow_pickle=False)
    assert mine.dtype == numpy_s.dtype and mine.shape == numpy_s.shape
    assert np.array_equal(mine, numpy_s)


def test_every_shipped_policy_reads_as_numpy_reads_it():
    paths = [
        os.path.join(d, exported.FILE)
        for d, _, names in os.walk(RUNS)
        if exported.FILE in names  # the shipped exported policies
    ]
    assert len(paths) >= 40
    for path in paths:
        with np.load(path, allow_pickle=False) as theirs:
            expected = {k: theirs[k] for k in theirs.files}
        mine = exported.load_npz(path)
        assert list(mine) == list(expected)
        for key, value in expected.items():
            assert mine[key].dtype == value.dtype and np.array_equal(mine[key], value), key


def _copy(tmp_path, source, method, name) -> str:
    dest = tmp_path / "runs" / method / "darwin_walk" / name
    shutil.copytree(source, dest)
    return str(dest)


def _actions_run(tmp_path, data: bytes) -> str:
    """A shipped gait run made an action-table run: its table is scored first."""
    run = _copy(tmp_path, GAIT_RUN, "plan", "T_seed0")
    with open(os.path.join(run, admission.ACTIONS), "wb") as f:
        f.write(data)
    return run


def _policy_run(tmp_path, member: str, data: bytes) -> str:
    """A shipped PPO run whose policy's `member` is replaced by `data`."""
    run = _copy(tmp_path, PPO_RUN, "ppo", "joints_seed0")
    path = os.path.join(run, admission.EXPORTED)
    with zipfile.ZipFile(path) as z:
        members = {n: z.read(n) for n in z.namelist()}
    members[member] = data
    with zipfile.ZipFile(path, "w") as z:
        for name, value in members.items():
            z.writestr(name, value)
    return run


def _board_refusal(run: str) -> str:
    """The one-line reason the board gives `run` (asserting it refuses it, without raising)."""
    found, skipped = leaderboard.find_runs(os.path.dirname(os.path.dirname(os.path.dirname(run))))
    admitted, refused = leaderboard.admit(found)
    assert admitted == [] and len(refused) == 1, (admitted, refused, skipped)
    reason = refused[0]["reason"]
    assert reason and reason.isprintable(), reason
    assert reason == admission.refusals([run]).get(run)
    return reason


def test_an_honest_action_table_and_policy_are_admitted(tmp_path):
    run = _actions_run(tmp_path / "a", _npy(np.zeros((STEPS, 12))))
    assert admission.refusals([run]) == {}
    run = _copy(tmp_path / "p", PPO_RUN, "ppo", "joints_seed0")
    assert admission.refusals([run]) == {}


@pytest.mark.parametrize("lie", sorted(LIES))
def test_the_board_refuses_an_action_table_whose_header_lies(tmp_path, lie):
    run = _actions_run(tmp_path, LIES[lie](np.zeros((STEPS, 12))))
    assert admission.ACTIONS in _board_refusal(run)


@pytest.mark.parametrize("member", ["mean.npy", "kernel_0.npy", "action_space.npy"])
@pytest.mark.parametrize("lie", sorted(LIES))
def test_the_board_refuses_a_policy_whose_member_header_lies(tmp_path, lie, member):
    with zipfile.ZipFile(os.path.join(PPO_RUN, admission.EXPORTED)) as z:
        honest = np.load(io.BytesIO(z.read(member)), allow_pickle=False)
    run = _policy_run(tmp_path, member, LIES[lie](honest))
    assert admission.EXPORTED in _board_refusal(run)


@pytest.mark.filterwarnings("ignore:Duplicate name")
@pytest.mark.parametrize(
    "member, data",
    [
        ("notes.txt", b"a member that is no array"),
        ("kernel_0.npy", None),  # a second kernel_0: which one would count?
        ("extra.npy", b""),
    ],
)
def test_the_board_refuses_a_policy_archive_that_is_not_plain_arrays(tmp_path, member, data):
    run = _copy(tmp_path, PPO_RUN, "ppo", "joints_seed0")
    path = os.path.join(run, admission.EXPORTED)
    with zipfile.ZipFile(path) as z:
        added = z.read(member) if data is None else data
    with zipfile.ZipFile(path, "a") as z:
        z.writestr(member, added)
    assert admission.EXPORTED in _board_refusal(run)


def test_the_board_refuses_a_policy_file_that_is_no_zip(tmp_path):
    run = _copy(tmp_path, PPO_RUN, "ppo", "joints_seed0")
    with open(os.path.join(run, admission.EXPORTED), "wb") as f:
        f.write(b"not a zip at all")
    assert admission.EXPORTED in _board_refusal(run)


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf, 1.5])
def test_the_board_refuses_an_action_table_with_one_value_not_finite_or_out_of_range(
    tmp_path, value
):
    table = np.zeros((STEPS, 12))
    table[STEPS // 2, 7] = value
    run = _actions_run(tmp_path, _npy(table))
    reason = _board_refusal(run)
    assert reason.startswith(f"its {admission.ACTIONS} holds"), reason


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("member", ["mean.npy", "var.npy", "kernel_1.npy", "bias_2.npy"])
def test_the_board_refuses_a_policy_with_one_value_not_finite(tmp_path, value, member):
    with zipfile.ZipFile(os.path.join(PPO_RUN, admission.EXPORTED)) as z:
        array = np.load(io.BytesIO(z.read(member)), allow_pickle=False).copy()
    array.flat[array.size // 2] = value
    run = _policy_run(tmp_path, member, _npy(array))
    reason = _board_refusal(run)
    assert "not finite" in reason and repr(member[:-4]) in reason, reason


# Names that are not printable text: a newline (forges a line), a carriage return, a tab,
# an escape sequence, DEL, a right-to-left override and a zero-width space (hide text), a
# line separator.
UNPRINTABLE = ["evil\nok   fake", "cr\rx", "tab\tx", "\x1b[31mred", "del\x7f", "bidi\u202eman"]
UNPRINTABLE += ["zero\u200bwidth", "line\u2028sep"]


def _not_admitted_lines(tmp_path, runs) -> tuple[list[str], list[dict]]:
    """The board's not-admitted file as lines of text, and as rows."""
    out = tmp_path / "board" / "leaderboard.csv"
    leaderboard.write_tables(str(runs), str(out))
    path = out.parent / "darwin_not_admitted.csv"
    with open(path, newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    return path.read_text(encoding="utf-8").splitlines(), rows


@pytest.mark.parametrize("name", UNPRINTABLE)
@pytest.mark.parametrize("level", ["run", "method", "file"])
def test_a_name_that_is_not_printable_is_refused_escaped_and_forges_no_line(tmp_path, name, level):
    _copy(tmp_path, GAIT_RUN, "cem", "K50_n0.8_e2_seed0")
    if level == "run":
        run = _copy(tmp_path, GAIT_RUN, "cem", f"{name}_seed3")
    elif level == "method":
        run = _copy(tmp_path, GAIT_RUN, name, "K50_seed3")
    else:
        run = _copy(tmp_path, GAIT_RUN, "mine", "K50_seed3")
        with open(os.path.join(run, name), "w") as f:
            f.write("a file whose name is not printable\n")
    lines, refused = _not_admitted_lines(tmp_path, tmp_path / "runs")
    assert len(lines) == 2, lines  # the header and one row: no line forged
    (row,) = refused
    assert all(str(v).isprintable() for v in row.values()), row
    assert repr(name)[1:-1] in row["reason"] and "printable" in row["reason"], row["reason"]
    assert all(line.isprintable() for line in lines), lines


def test_a_folder_above_the_runs_whose_name_is_not_printable_is_refused(tmp_path):
    ok = _copy(tmp_path / "ok", GAIT_RUN, "cem", "K50_n0.8_e2_seed0")
    evil = _copy(tmp_path / "evil\nline", GAIT_RUN, "cma", "K_seed1")
    reasons = admission.refusals([ok, evil])
    assert list(reasons) == [evil]
    assert reasons[evil].startswith("a folder above it's name 'evil\\nline'")


def test_symlinked_run_task_and_method_folders_are_listed_not_dropped(tmp_path):
    real = _copy(tmp_path, GAIT_RUN, "cem", "K50_n0.8_e2_seed0")
    runs = tmp_path / "runs"
    os.symlink(
        os.path.join(RUNS, "cem", "darwin_walk", "K50_n0.8_e2_seed1"),
        os.path.join(os.path.dirname(real), "K50_n0.8_e2_seed1"),
    )
    os.symlink(os.path.join(RUNS, "cmaes"), runs / "cmaes")  # a method's folder
    (runs / "ppo").mkdir()
    os.symlink(os.path.join(RUNS, "ppo", "darwin_walk"), runs / "ppo" / "darwin_walk")
    found, _ = leaderboard.find_runs(str(runs))
    admitted, refused = leaderboard.admit(found)
    assert [r["dir"] for r in admitted] == [real]
    listed = {(r["method"], r["training_task"], r["seed"]): r["reason"] for r in refused}
    assert listed == {
        ("cem", "darwin_walk", 1): admission.LINK_REFUSAL,
        ("cmaes", "", ""): admission.LINK_REFUSAL,
        ("ppo", "darwin_walk", ""): admission.LINK_REFUSAL,
    }
    # nothing through a link is read: no run inside the linked method's folder is found
    assert all("cmaes" not in os.path.relpath(r["dir"], runs)[6:] for r in found)


@pytest.mark.parametrize("digits", ["\u0660", "\uff11", "\u0967", "1\u0660", "\U0001d7ce"])
def test_a_seed_in_digits_other_than_ascii_is_refused_and_displaces_no_seed(tmp_path, digits):
    real = _copy(tmp_path, GAIT_RUN, "cem", "K50_n0.8_e2_seed0")
    odd = _copy(
        tmp_path,
        os.path.join(RUNS, "cem", "darwin_walk", "K50_n0.8_e2_seed1"),
        "cem",
        f"K50_n0.8_e2_seed{digits}",
    )
    assert admission.SEED_NAME.match(os.path.basename(odd)) is None
    assert leaderboard._SEED is admission.SEED_NAME
    found, _ = leaderboard.find_runs(str(tmp_path / "runs"))
    admitted, refused = leaderboard.admit(found)
    assert [r["dir"] for r in admitted] == [real]
    (row,) = refused
    assert row["seed"] == "" and "not in ASCII digits" in row["reason"], row
    assert repr(os.path.basename(odd)) in row["reason"]


def test_the_file_check_refuses_a_symlinked_gait(tmp_path):
    run = _copy(tmp_path, GAIT_RUN, "cem", "K50_n0.8_e2_seed0")
    os.remove(os.path.join(run, "selected_params.json"))
    os.symlink(
        os.path.join(RUNS, "cem", "darwin_walk", "K50_n0.8_e2_seed1", "selected_params.json"),
        os.path.join(run, "selected_params.json"),
    )
    assert admission.file_refusal(run) == (
        "selected_params.json is a symbolic link, not a file of the run's own"
    )


def test_ship_from_refuses_a_symlinked_gait_in_one_line_and_goes_on(tmp_path):
    root = tmp_path / "finished"
    run = root / "cem" / "darwin_walk" / "a_seed0"
    shutil.copytree(GAIT_RUN, run)
    os.remove(run / "trials.csv")
    (tmp_path / "elsewhere.json").write_text("not the gait: another file's content")
    os.remove(run / "selected_params.json")
    os.symlink(tmp_path / "elsewhere.json", run / "selected_params.json")
    half = root / "cem" / "darwin_walk" / "b_seed1"
    half.mkdir()
    (half / "summary.json").write_text("{}")
    logged = []
    shipped = verify.ship_all(str(root), str(tmp_path / "shipped"), log=logged.append)
    assert shipped == 0
    assert logged[0] == (
        f"not shipped {run}: selected_params.json is a symbolic link, not a file of the run's own"
    )
    assert logged[1].startswith(f"not shippable {half}: missing ")
    assert not (tmp_path / "shipped").exists()


@pytest.mark.parametrize(
    "member, array",
    [
        ("mean.npy", np.float64(0.0)),  # a 0-d normalizer
        ("kernel_0.npy", np.zeros((5, 0))),  # a layer of no outputs
        ("bias_0.npy", np.zeros(3)),  # a bias of another width than its kernel
        ("kernel_1.npy", np.zeros((7, 64))),  # rows that are not the last layer's outputs
    ],
)
def test_the_board_refuses_a_policy_whose_layers_do_not_fit(tmp_path, member, array):
    """Each array honest on its own, the policy they make is none the scorer can run (a
    second outside attack, 2026-11-29: a 0-d mean and a 0-column kernel were admitted,
    then verify could not score them): refused in one line."""
    run = _policy_run(tmp_path, member, _npy(np.asarray(array)))
    assert "is no policy the scorer can run" in _board_refusal(run)


def test_the_board_refuses_a_policy_that_answers_no_leg_action(tmp_path):
    """Its arrays fit together, but its last layer has one output fewer than the shipped
    policy's: its action is not 12 leg actions."""
    with zipfile.ZipFile(os.path.join(PPO_RUN, admission.EXPORTED)) as z:
        last = max(int(n[len("kernel_") : -4]) for n in z.namelist() if n.startswith("kernel_"))
        kernel = np.load(io.BytesIO(z.read(f"kernel_{last}.npy")))
    width = kernel.shape[1] - 1
    run = _policy_run(tmp_path, f"kernel_{last}.npy", _npy(kernel[:, :width]))
    path = os.path.join(run, admission.EXPORTED)
    with zipfile.ZipFile(path) as z:
        members = {n: z.read(n) for n in z.namelist()}
    members[f"bias_{last}.npy"] = _npy(np.zeros(width))
    with zipfile.ZipFile(path, "w") as z:
        for name, value in members.items():
            z.writestr(name, value)
    reason = _board_refusal(run)
    assert "no policy the scorer can run" in reason or "not 12 finite leg actions" in reason


@pytest.mark.parametrize(
    "level, name",
    [
        ("run", "K50_n0.8_e2_seed0 "),  # a trailing space
        ("run", " K50_n0.8_e2_seed0"),
        ("run", "K50_n0.8_e\u0301_seed0"),  # a combining accent
        ("method", "\u0441em"),  # a Cyrillic с
    ],
)
def test_a_name_that_only_looks_like_another_is_refused(tmp_path, level, name):
    """Printable names that read as another's (a second outside attack, 2026-11-29: a
    Cyrillic method and a trailing space each made a board row that reads like cem's)."""
    method, run_name = (name, "K50_n0.8_e2_seed0") if level == "method" else ("cem", name)
    run = _copy(tmp_path, GAIT_RUN, method, run_name)
    found, _ = leaderboard.find_runs(str(tmp_path / "runs"))
    admitted, refused = leaderboard.admit(found)
    assert admitted == [] and len(refused) == 1, (admitted, refused)
    assert "outside ASCII or starts or ends with a space" in refused[0]["reason"]
    assert repr(name) in refused[0]["reason"] and run


@pytest.mark.parametrize(
    "name",
    [
        "K50_n0.8_e2",
        "K50_n0.8_e2_seed",
        "K50_n0.8_e2_seed0_copy",
        "0",
        "seed0",  # no configuration (was read as "default")
        "_seed0",
        "K50_n0.8_e2seed0",  # no underscore (was configuration "K50_n0.8_e2")
        "K50seed1",
        "_seed",
    ],
)
def test_a_run_whose_folder_names_no_seed_is_refused_in_one_line(tmp_path, name):
    """A run folder must be `<configuration>_seed<N>`, the configuration not empty: the
    board counts a configuration's seeds by its runs' names, and a seedless name was
    admitted as a configuration of its own (a third outside attack's finding, 2026-11-29):
    a copy renamed so would be a 'configuration' beside the original's, one seed each
    (`seed0` and `_seed0` as "default", `K50seed0` as "K50": a fourth reading's finding)."""
    run = _copy(tmp_path, GAIT_RUN, "cem", name)
    reason = _board_refusal(run)
    assert reason.startswith(f"its folder's name {name} is not <configuration>_seed<N>"), reason


def _leaves(tree, path=()):
    """Every number and flag in a JSON tree, as (path of keys, value)."""
    if isinstance(tree, dict):
        for key, value in tree.items():
            yield from _leaves(value, (*path, key))
    elif isinstance(tree, (bool, int, float)):
        yield path, tree


def _forged(value):
    """A value the submitter would rather have: a flag flipped, a number raised."""
    if isinstance(value, bool):
        return not value
    return value + 7 if isinstance(value, int) else value * 1.25 + 1.0


def _board_files(runs, out) -> dict[str, str]:
    """Every file the board's command writes for a run tree, by name."""
    leaderboard.write_tables(str(runs), str(out / "leaderboard.csv"))
    return {p.name: p.read_text(encoding="utf-8") for p in sorted(out.iterdir())}


# What a run's summary says beside its cards that the board shows as the submitter's word:
# its budget. Claiming more of it can only move the run to a larger budget's track; less
# than its config gave it is refused (`admission.training_refusal`).
BUDGET = {("evaluations",), ("sim_steps",), ("validation_sim_steps",), ("env_steps",)}


@pytest.mark.parametrize("source", [GAIT_RUN, PPO_RUN], ids=["gait", "policy"])
def test_a_summary_number_that_nothing_re_makes_changes_nothing_the_board_writes(tmp_path, source):
    """helper-43's finding (2026-11-29): a copy alone in its tree, its summary's
    `final_mean_distance_m` raised, was admitted and its training record counted in the
    study's metrics. As a class: each number or flag a summary holds outside its cards and
    its in-sample best tried again (which verify re-makes), raised on its own, leaves
    every file the board writes as it was, or has the run refused; only the budget shows,
    and it only changes the track."""
    name = os.path.basename(source)
    method = os.path.basename(os.path.dirname(os.path.dirname(source)))
    honest = _copy(tmp_path / "honest", source, method, name)
    before = _board_files(tmp_path / "honest" / "runs", tmp_path / "honest" / "board")
    summary = json.loads(open(os.path.join(honest, "summary.json"), encoding="utf-8").read())
    leaves = [
        (path, value)
        for path, value in _leaves(summary)
        if path[0] not in ("test", "history", "in_sample")
    ]
    assert len(leaves) >= 8, leaves
    for i, (path, value) in enumerate(leaves):
        forged = json.loads(json.dumps(summary))
        node = forged
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = _forged(value)
        root = tmp_path / f"forged{i}"
        run = _copy(root, source, method, name)
        with open(os.path.join(run, "summary.json"), "w", encoding="utf-8") as f:
            json.dump(forged, f)
        after = _board_files(root / "runs", root / "board")
        refused = list(csv.DictReader(io.StringIO(after["darwin_not_admitted.csv"])))
        if refused:
            assert len(refused) == 1 and refused[0]["reason"].isprintable(), (path, refused)
        elif path not in BUDGET:
            assert after == before, f"{'.'.join(path)} raised shows on the board"


def test_a_training_record_forged_in_both_its_files_changes_nothing_the_board_writes(tmp_path):
    """The in-sample best's training record raised where admission cross-checks it
    (`summary.json`'s `best_distance_m` and its `IN_SAMPLE` gait's `distance_m`, alike):
    the files hold together and the run is admitted, but the board shows the in-sample best
    tried again (which verify re-makes), so nothing it writes changes."""
    name = os.path.basename(GAIT_RUN)
    _copy(tmp_path / "honest", GAIT_RUN, "cem", name)
    before = _board_files(tmp_path / "honest" / "runs", tmp_path / "honest" / "board")
    run = _copy(tmp_path / "forged", GAIT_RUN, "cem", name)
    for file, key in (("summary.json", "best_distance_m"), (admission.IN_SAMPLE, "distance_m")):
        path = os.path.join(run, file)
        record = json.loads(open(path, encoding="utf-8").read())
        record[key] = 9.9
        with open(path, "w", encoding="utf-8") as f:
            json.dump(record, f)
    assert admission.run_refusal(run) is None
    after = _board_files(tmp_path / "forged" / "runs", tmp_path / "forged" / "board")
    assert after == before


def _edit_summary(run: str, change) -> None:
    path = os.path.join(run, "summary.json")
    summary = json.loads(open(path, encoding="utf-8").read())
    change(summary)
    with open(path, "w", encoding="utf-8") as f:
        json.dump(summary, f)


@pytest.mark.parametrize("depth", [33, 900, 20_000])
def test_a_run_file_nested_too_deep_is_refused_in_one_line_and_the_board_goes_on(tmp_path, depth):
    """An outside attack of 2026-11-29: an extra key nested 900 deep in a test card's row
    and its history card's sent the card comparison past Python's recursion limit, and the
    board wrote nothing. As a class: JSON nested past `files.MAX_JSON_DEPTH`, however deep,
    is refused when read."""
    run = _copy(tmp_path, GAIT_RUN, "cem", os.path.basename(GAIT_RUN))

    def deepen(summary):
        for card in (summary["test"], *summary.get("history", {}).values()):
            card["tiers"]["darwin_walk"]["x"] = "DEEP"

    _edit_summary(run, deepen)
    path = os.path.join(run, "summary.json")
    text = open(path, encoding="utf-8").read()  # past what `json.dump` writes
    with open(path, "w", encoding="utf-8") as f:
        f.write(text.replace('"DEEP"', '{"a": ' * (depth - 1) + "{}" + "}" * (depth - 1)))
    files = _board_files(tmp_path / "runs", tmp_path / "board")
    (row,) = csv.DictReader(io.StringIO(files["darwin_not_admitted.csv"]))
    assert row["reason"] == (
        "unreadable run files (ValueError: summary.json: nested more than 32 lists and "
        "objects deep)"
    )


def test_the_deepest_shipped_run_file_nests_well_within_the_limit():
    deepest = 0
    for dirpath, _, names in os.walk(RUNS):
        for name in names:
            if name.endswith(".json"):
                with open(os.path.join(dirpath, name), encoding="utf-8") as f:
                    deepest = max(deepest, files_module._depth(json.load(f)))
    assert 3 <= deepest <= files_module.MAX_JSON_DEPTH // 2


@pytest.mark.parametrize(
    "text",
    ["x\r\n3,darwin_walk,cem,FORGED,1,cem/darwin_walk/FORGED_seed1,forged", "a\u2028b\x1b[2K"],
)
def test_a_reason_quoting_a_runs_own_text_is_one_printable_line(tmp_path, text):
    """An outside attack of 2026-11-29: a card's `not_protocol` entry is quoted in the
    refusal, and its newline forged a row of the not-admitted listing. Every reason is
    printed with its other characters escaped (`admission.shown_reason`)."""
    run = _copy(tmp_path, GAIT_RUN, "cem", os.path.basename(GAIT_RUN))
    _edit_summary(run, lambda s: s["test"].update(not_protocol=[text]))
    files = _board_files(tmp_path / "runs", tmp_path / "board")
    lines = files["darwin_not_admitted.csv"].splitlines()
    assert len(lines) == 2, lines
    (row,) = csv.DictReader(io.StringIO(files["darwin_not_admitted.csv"]))
    assert row["reason"].isprintable() and "FORGED" not in row["run"]
    assert row["reason"] == admission.refusals([run]).get(run)


@pytest.mark.parametrize("ledger", ["bytes", "folder"])
def test_a_ledger_the_board_may_not_read_vouches_for_none_and_the_board_goes_on(tmp_path, ledger):
    """An outside attack of 2026-11-29: a `rescored.csv` beside the tree in bytes that are
    not UTF-8, or a folder of that name, made the board raise and write nothing. It is
    now listed as skipped, and no run counts as re-scored."""
    _copy(tmp_path, GAIT_RUN, "cem", os.path.basename(GAIT_RUN))
    path = tmp_path / admission.LEDGER
    if ledger == "bytes":
        path.write_bytes(b"run,check\n\xff\xfe,full\n")
    else:
        path.mkdir()
    found, skipped = leaderboard.find_runs(str(tmp_path / "runs"))
    assert len(skipped) == 1 and "rescored.csv" in skipped[0] and skipped[0].isprintable()
    files = _board_files(tmp_path / "runs", tmp_path / "board")
    (row,) = csv.DictReader(io.StringIO(files["darwin_leaderboard.csv"]))
    assert row["rescored_full_runs"] in ("", "0")


def _relabelled(source: str, dest: str, version: int = 2) -> None:
    """A copy of a version-1 run that claims to have trained under `version` (on the task
    of the folder it is copied to): its config says so, and its cards and tables of earlier
    versions are gone."""
    shutil.copytree(source, dest)
    config = json.loads(open(os.path.join(dest, "config.json"), encoding="utf-8").read())
    config["settings"]["benchmark_version"] = version
    config["settings"]["task"] = os.path.basename(os.path.dirname(dest))
    with open(os.path.join(dest, "config.json"), "w", encoding="utf-8") as f:
        json.dump(config, f)

    def drop_history(summary):
        kept = {k: c for k, c in summary.get("history", {}).items() if int(k[1:]) >= version}
        summary.pop("history", None)
        if kept:
            summary["history"] = kept

    _edit_summary(dest, drop_history)
    for earlier in range(1, version):
        path = os.path.join(dest, f"trials_v{earlier}.csv")
        if os.path.exists(path):
            os.remove(path)


V1_RUN = os.path.join(RUNS, "ppo", "darwin_walk", "cpg_v1_seed0")


@pytest.mark.parametrize(
    "method, name",
    [
        ("zz_mine", "cpg_seed0"),
        ("ppo", "other_seed0"),
        ("ppo", "cpg_v7_seed0"),
        ("ppo", "cpg_v2_seed0"),
        ("ppo", "cpg_v1_v2_seed0"),  # helper-46: `<config>` cpg_v1, "re-run" of cpg_v1_seed0
    ],
)
def test_a_version_1_run_relabelled_as_a_later_version_under_another_name_is_a_copy(
    tmp_path, method, name
):
    """An outside attack of 2026-11-29: version-1 runs copied under another method and
    relabelled as trained under version 2 (config, history and tables consistent) were
    ranked 3rd, as the copy check compared only runs that claim the same training
    physics. Now only a configuration's own seed trained again under another version is
    exempt (`admission._retrained`)."""
    runs = tmp_path / "runs"
    original = runs / "ppo" / "darwin_walk" / "cpg_v1_seed0"
    shutil.copytree(V1_RUN, original)
    copy = runs / method / "darwin_walk" / name
    _relabelled(V1_RUN, str(copy))
    assert admission.refusals([str(copy)]) == {}  # alone, its files hold together
    reasons = admission.refusals([str(original), str(copy)])
    assert list(reasons) == [str(copy)]
    assert reasons[str(copy)].startswith(
        "a copy of ppo/darwin_walk/cpg_v1_seed0, which trained under other physics: the same "
    )


def test_a_configurations_own_seed_trained_again_under_version_2_is_not_a_copy(tmp_path):
    """The shipped pairs the exemption is for: a CEM seed trained to the same gait under
    versions 1 and 2 (`K50_n0.8_e2_v1_seed3`, `K50_n0.8_e2_seed3`) are both admitted."""
    pair = []
    for name in ("K50_n0.8_e2_v1_seed3", "K50_n0.8_e2_seed3"):
        pair.append(_copy(tmp_path, os.path.join(RUNS, "cem", "darwin_walk", name), "cem", name))
    assert admission.refusals(pair) == {}
    prints = [
        copies.fingerprint(d, admission.artifact_files(d), admission.read_trials(f"{d}/trials.csv"))
        for d in pair
    ]
    assert copies.copy_of(*prints)  # without the exemption, one would be refused
    # What stays the submitter's word (docs/protocol.md#admission): a version-1 run copied
    # to its configuration's plain name and relabelled as version 2 is that re-run.
    v1 = _copy(tmp_path / "v1", V1_RUN, "ppo", "cpg_v1_seed0")
    relabelled = tmp_path / "v1" / "runs" / "ppo" / "darwin_walk" / "cpg_seed0"
    _relabelled(V1_RUN, str(relabelled))
    assert admission.refusals([v1, str(relabelled)]) == {}


def test_a_copy_one_folder_deeper_is_refused_and_displaces_no_original(tmp_path):
    """An outside attack of 2026-11-29: a byte copy at `runs/a/ppo/darwin_walk/cpg_seed1`
    shared its original's ledger row (the last three names) and, sorting first, had the
    original refused as its copy. A run deeper than <method>/<task>/<run> is refused."""
    source = os.path.join(RUNS, "ppo", "darwin_walk", "cpg_seed1")
    original = _copy(tmp_path, source, "ppo", "cpg_seed1")
    shutil.copytree(source, tmp_path / "runs" / "a" / "ppo" / "darwin_walk" / "cpg_seed1")
    found, _ = leaderboard.find_runs(str(tmp_path / "runs"))
    admitted, refused = leaderboard.admit(found)
    assert [r["dir"] for r in admitted] == [original]
    (row,) = refused
    assert row["run"].startswith("a/") and row["reason"] == admission.DEPTH_REFUSAL


def test_a_trial_table_past_its_size_is_refused_before_its_rows_are_built(tmp_path):
    """An outside attack of 2026-11-29: a 64 MiB trial table of valid short rows cost
    about 3 GB of memory before its row count was checked. A table over
    `admission.MAX_TRIAL_TABLE_CHARS` is refused as it is read; every shipped one is far
    below it."""
    run = _copy(tmp_path, GAIT_RUN, "cem", os.path.basename(GAIT_RUN))
    path = os.path.join(run, "trials.csv")
    text = open(path, encoding="utf-8", newline="").read()
    header, first = text.split("\r\n")[:2]
    count = admission.MAX_TRIAL_TABLE_CHARS // len(first) + 1
    with open(path, "w", encoding="utf-8", newline="") as f:
        f.write(header + "\r\n" + (first + "\r\n") * count)
    reason = admission.run_refusal(run)
    assert reason.startswith("unreadable run files (ValueError: trials.csv holds ")
    assert reason.endswith(f"over the {admission.MAX_TRIAL_TABLE_CHARS} a trial table may hold)")
    assert _largest_shipped(lambda name: name.startswith("trials")) * 10 < (
        admission.MAX_TRIAL_TABLE_CHARS
    )


def _largest_shipped(kind) -> int:
    """The size in bytes of the largest shipped run file whose name is of `kind`."""
    return max(
        os.path.getsize(os.path.join(d, n))
        for d, _, names in os.walk(RUNS)
        for n in names
        if kind(n)
    )


def _ledger_for(tmp_path, runs: list[str]) -> None:
    """A ledger beside the tree recording `runs` as re-scored in full and reproduced with
    their present files, as `verify --record` writes it."""
    rows = [
        f"{admission.run_key(run)},{admission.run_digest(run)},full,250,reproduced,x,x"
        for run in runs
    ]
    text = ",".join(admission.LEDGER_FIELDS) + "\n" + "\n".join(rows) + "\n"
    (tmp_path / admission.LEDGER).write_text(text, encoding="utf-8")


@pytest.mark.parametrize("given", ["runs", "runs/ppo", "runs/ppo/darwin_walk"])
def test_the_board_reads_the_tree_it_is_given_and_the_ledger_beside_it(tmp_path, given):
    """helper-46 (2026-11-29): given a method's or a task's folder, the board read the ledger
    beside that folder, inside the tree, so a copy that says it started first displaced the
    original the ledger records; helper-47: taking the tree's depth from its runs let a decoy
    folder move it. The board reads `<method>/<task>/<run>` under the folder it is given
    and the ledger beside that folder: given a method's or a task's folder, every run is
    refused, with why, and none displaces another."""
    source = os.path.join(RUNS, "ppo", "darwin_walk", "joints_seed1")
    original = _copy(tmp_path, source, "ppo", "joints_seed1")
    copy = _copy(tmp_path, source, "ppo", "early_seed1")
    path = os.path.join(copy, "config.json")
    config = json.loads(open(path, encoding="utf-8").read())
    config["environment"]["started_utc"] = "2000-01-01T00:00:00Z"
    with open(path, "w", encoding="utf-8") as f:
        json.dump(config, f)
    _ledger_for(tmp_path, [original])
    found, _ = leaderboard.find_runs(str(tmp_path / given))
    admitted, refused = leaderboard.admit(found)
    if given != "runs":
        assert admitted == [] and {r["reason"] for r in refused} == {admission.DEPTH_REFUSAL}
        return
    assert [r["dir"] for r in admitted] == [original]
    assert admitted[0]["rescored_on"] == "x"  # the ledger's date column
    (row,) = refused
    assert row["reason"].startswith("a copy of ppo/darwin_walk/joints_seed1")


@pytest.mark.parametrize(
    "decoy",
    ["ppo/notes/x/.a.partial-0", "ppo/evil/darwin_walk/joints_seed2", "ppo/joints_seed3"],
)
def test_a_decoy_folder_at_another_depth_is_refused_and_moves_nothing(tmp_path, decoy):
    """helper-47 (2026-11-29): an empty half-written folder, or a run one level deeper, moved
    the depth the board read the tree at, and with it the ledger, so honest runs were
    refused and a planted ledger read. A folder at another depth moves nothing now."""
    source = os.path.join(RUNS, "ppo", "darwin_walk", "joints_seed1")
    original = _copy(tmp_path, source, "ppo", "joints_seed1")
    _ledger_for(tmp_path, [original])
    shutil.copytree(source, tmp_path / "runs" / decoy)
    (tmp_path / "runs" / admission.LEDGER).write_text("forged", encoding="utf-8")
    found, _ = leaderboard.find_runs(str(tmp_path / "runs"))
    admitted, refused = leaderboard.admit(found)
    assert [r["dir"] for r in admitted] == [original] and admitted[0]["rescored_on"] == "x"
    assert [r["reason"] for r in refused] in ([], [admission.DEPTH_REFUSAL])


@pytest.mark.parametrize("where", ["inside", "beside"])
def test_a_run_is_named_by_its_place_however_its_folder_is_written(tmp_path, monkeypatch, where):
    """helper-46 (2026-11-29): `--runs=.` from inside a task's folder found no run (its
    relative path held fewer than three names), and `--runs=../darwin_walk` named the
    method `..`. Names come from the absolute path, and the run is listed as refused (a
    task's folder is not a tree), not left out."""
    run = _copy(tmp_path, GAIT_RUN, "cem", os.path.basename(GAIT_RUN))
    if where == "inside":
        monkeypatch.chdir(os.path.dirname(run))
        root = "."
    else:
        os.makedirs(tmp_path / "runs" / "cem" / "other")
        monkeypatch.chdir(tmp_path / "runs" / "cem" / "other")
        root = os.path.join(os.pardir, "darwin_walk")
    found, skipped = leaderboard.find_runs(root)
    assert skipped == []
    (one,) = found
    named = (one["method"], one["task"], one["config"], one["seed"])
    assert named == ("cem", "darwin_walk", "K50_n0.8_e2", 0)
    admitted, (row,) = leaderboard.admit(found)  # a task's folder is not a tree: said so
    assert admitted == [] and row["reason"] == admission.DEPTH_REFUSAL
    assert row["method"] == "cem"


def test_a_json_file_past_its_size_is_refused_before_it_is_parsed(tmp_path):
    """helper-46 (2026-11-29): a summary.json padded to 64 MiB of empty objects took 7
    minutes and 4.9 GB, and was admitted. A run's JSON over `files.MAX_JSON_BYTES` is
    refused when read; the largest shipped is far below it."""
    run = _copy(tmp_path, GAIT_RUN, "cem", os.path.basename(GAIT_RUN))
    _edit_summary(run, lambda s: s.update(junk=[{}] * (files_module.MAX_JSON_BYTES // 3)))
    reason = admission.run_refusal(run)
    assert reason.startswith("unreadable run files (ValueError: summary.json holds ")
    assert reason.endswith(f"over the {files_module.MAX_JSON_BYTES} a run's JSON file may hold)")
    assert _largest_shipped(lambda name: name.endswith(".json")) * 20 < files_module.MAX_JSON_BYTES


def test_a_version_1_run_relabelled_on_another_training_task_is_a_copy(tmp_path):
    """helper-47 (2026-11-29): `ppo/darwin_walk_randomized/cpg_seed0`, a version-1
    `ppo/darwin_walk/cpg_v1_seed0` relabelled as version 2 and as trained on another task,
    passed as its re-run (the exemption ignored the task) and was ranked."""
    runs = tmp_path / "runs"
    original = runs / "ppo" / "darwin_walk" / "cpg_v1_seed0"
    shutil.copytree(V1_RUN, original)
    copy = runs / "ppo" / "darwin_walk_randomized" / "cpg_seed0"
    _relabelled(V1_RUN, str(copy))
    assert admission.refusals([str(copy)]) == {}
    reasons = admission.refusals([str(original), str(copy)])
    assert (
        list(reasons) == [str(copy)] and "which trained under other physics" in reasons[str(copy)]
    )


def test_a_policy_whose_arrays_hold_too_many_values_is_refused_before_they_are_widened(
    tmp_path,
):
    """helper-47 (2026-11-29): a 97 KB archive of one 8000 × 8000 boolean kernel, widened to
    float64 by the policy and the copy check, cost 1.2 GB a run. An array, or an archive,
    of more than `exported.MAX_VALUES` values is refused from its header."""
    side = int(exported.MAX_VALUES**0.5) + 1
    run = _policy_run(tmp_path, "kernel_1.npy", _npy(np.zeros((side, side), dtype=bool)))
    assert "over the 2097152 values a run's arrays may hold" in _board_refusal(run)


def test_a_learners_physics_steps_below_its_control_steps_are_refused(tmp_path):
    """helper-47 (2026-11-29): a learner's `sim_steps` lowered to its `env_steps` showed a
    budget 8 times smaller than it simulated. Each control step takes
    `PHYSICS_STEPS_PER_CONTROL_STEP` physics steps, as every shipped learner claims."""
    run = _copy(tmp_path, PPO_RUN, "ppo", os.path.basename(PPO_RUN))
    _edit_summary(run, lambda s: s.update(sim_steps=s["env_steps"]))
    assert _board_refusal(run).startswith(
        "summary.json claims 2502656 physics steps (sim_steps), fewer than its 2502656 "
        "training control steps take (8 each at least)"
    )


@pytest.mark.parametrize(
    "decoy", ["zz/deep/tokic/b_seed0", "pole/pole_balance/b_seed0", "cem/darwin_walk/b_seed0"]
)
def test_a_summary_with_an_integer_past_64_bits_is_skipped_and_the_board_goes_on(tmp_path, decoy):
    """helper-48 (2026-11-29): a decoy summary.json holding a 400-digit integer, at any depth
    and of any task, made the study's metrics raise OverflowError, and the board wrote
    nothing. JSON integers beyond 64 bits are refused when read."""
    run = _copy(tmp_path, GAIT_RUN, "cem", "K50_n0.8_e2_seed0")
    folder = tmp_path / "runs" / decoy
    folder.mkdir(parents=True)
    (folder / "summary.json").write_text('{"cycle_reward": -1' + "0" * 400 + "}")
    files = _board_files(tmp_path / "runs", tmp_path / "board")
    (row,) = csv.DictReader(io.StringIO(files["darwin_leaderboard.csv"]))
    assert row["config"] == "K50_n0.8_e2"
    assert admission.run_refusal(run) is None


def test_policy_code_past_its_size_is_refused_before_it_is_parsed(tmp_path):
    """helper-48 (2026-11-29): a 4 MB policy_code.py of one-line statements cost 2.6 GB when
    its syntax tree was built for the copy check. Code over `copies.MAX_CODE_CHARS` is
    refused first."""
    run = _copy(tmp_path, GAIT_RUN, "cem", "K50_n0.8_e2_seed0")
    os.remove(os.path.join(run, admission.GAIT))
    os.remove(os.path.join(run, admission.IN_SAMPLE))
    source = "import numpy as np\n\n\ndef make_policy():\n    return lambda o: np.zeros(12)\n"
    with open(os.path.join(run, admission.CODE), "w", encoding="utf-8") as f:
        f.write(source + "x = 1\n" * (copies.MAX_CODE_CHARS // 6 + 1))
    assert "over the 262144 a policy's code may hold" in _board_refusal(run)


@pytest.mark.parametrize("task", ["darwin_walk_foo", "darwin_w\u0430lk"])
def test_a_run_under_a_task_folder_that_is_no_tier_is_listed_and_refused(tmp_path, task):
    """helper-50 (2026-11-29): a run moved to `darwin_walk_foo` (its config saying so) was
    ranked on a tier that does not exist, and one under a lookalike `darwin_wаlk` (Cyrillic
    а) vanished from every listing. Both are listed as refused, in one line."""
    run = _copy(tmp_path, GAIT_RUN, "cem", "K50_n0.8_e2_seed0")
    moved = tmp_path / "runs" / "cem" / task / "K50_n0.8_e2_seed0"
    shutil.move(os.path.dirname(run), moved.parent)
    path = moved / "config.json"
    config = json.loads(path.read_text(encoding="utf-8"))
    config["settings"]["task"] = task
    path.write_text(json.dumps(config), encoding="utf-8")
    files = _board_files(tmp_path / "runs", tmp_path / "board")
    assert list(csv.DictReader(io.StringIO(files["darwin_leaderboard.csv"]))) == []
    (row,) = csv.DictReader(io.StringIO(files["darwin_not_admitted.csv"]))
    assert row["reason"].isprintable() and (
        "no DARwIn-OP walking task" in row["reason"] or ("ASCII" in row["reason"])
    ), row


@pytest.mark.parametrize("text", ["{", "[]", "null", '{"made_with": {"python": 5}}'])
def test_a_versions_record_that_is_not_verifys_is_refused(tmp_path, text):
    """helper-50 (2026-11-29): a versions.json of one `{`, or one naming versions as numbers,
    was admitted: only its presence was checked."""
    run = _copy(tmp_path, GAIT_RUN, "cem", "K50_n0.8_e2_seed0")
    with open(os.path.join(run, "versions.json"), "w", encoding="utf-8") as f:
        f.write(text)
    reason = _board_refusal(run)
    assert "versions.json" in reason, reason


# A sixth outside attack (helper-51, 2026-11-29).


def _nested(base, depth: int, name: str = "d") -> list[str]:
    """A chain of `depth` folders under `base`, made one level at a time (`os.makedirs`
    recurses, and fails at Python's recursion limit like the walk it tests): the folders,
    top first."""
    chain, path = [], str(base)
    for _ in range(depth):
        path = os.path.join(path, name)
        os.mkdir(path)
        chain.append(path)
    return chain


@pytest.mark.parametrize("where", ["root", "method", "run"])
def test_a_folder_tree_thousands_deep_is_listed_and_the_board_goes_on(tmp_path, where):
    """A 1,100-deep chain of empty folders beside a run crashed the board (Python 3.11's
    `os.walk` recurses: RecursionError, no file written). The walk is iterative and enters
    at most `files.MAX_TREE_DEPTH` folders; what lies deeper is listed as skipped, and the
    honest run beside it is still admitted. verify's walk of a tree is the same one."""
    run = _copy(tmp_path, GAIT_RUN, "cem", os.path.basename(GAIT_RUN))
    base = {"root": tmp_path / "runs", "method": tmp_path / "runs" / "cem", "run": run}[where]
    chain = _nested(base, 1100)
    try:
        found, skipped = leaderboard.find_runs(str(tmp_path / "runs"))
        assert any("deeper than 16 folders" in line and line.isprintable() for line in skipped)
        admitted, refused = leaderboard.admit(found)
        assert [r["dir"] for r in admitted] == [run] and refused == []
        assert verify.shipped_runs(str(tmp_path / "runs")) == [run]
        assert verify.run_folders(str(tmp_path / "runs")) == [run]
    finally:  # bottom up: pytest's clean-up of its temporary folders recurses too
        for path in reversed(chain):
            os.rmdir(path)


def test_the_walk_yields_what_os_walk_yields_in_name_order(tmp_path):
    """`files.walk_sorted` is `os.walk` top-down in name order: the same folders, their
    folder and file names sorted, a link to a folder listed and not entered."""
    shutil.copytree(os.path.join(RUNS, "cem"), tmp_path / "runs" / "cem")
    os.symlink(tmp_path / "runs" / "cem", tmp_path / "runs" / "link")
    (tmp_path / "runs" / "b.txt").write_text("x")
    ours = list(files_module.walk_sorted(str(tmp_path / "runs")))
    theirs = []
    for dirpath, dirnames, filenames in os.walk(tmp_path / "runs"):
        dirnames.sort()
        theirs.append((dirpath, list(dirnames), sorted(filenames)))
    assert ours == theirs and any("link" in d for _, d, _ in ours)


def test_a_refusal_that_quotes_a_huge_text_is_cut_to_one_short_line(tmp_path):
    """A 900,000-character task name in a run's config made a 900 KB line of the
    not-admitted listing: a reason is cut at `admission.MAX_REASON_CHARS`."""
    run = _copy(tmp_path, GAIT_RUN, "cem", os.path.basename(GAIT_RUN))
    path = os.path.join(run, "config.json")
    config = json.loads(open(path, encoding="utf-8").read())
    config["settings"]["task"] = "x" * 900_000 + "\n"
    with open(path, "w", encoding="utf-8") as f:
        json.dump(config, f)
    reason = _board_refusal(run)
    assert len(reason) < 2 * admission.MAX_REASON_CHARS and "more characters cut" in reason


@pytest.mark.parametrize(
    "source, dropped",
    [
        (GAIT_RUN, ("population", "rounds", "eval_seeds")),
        (PPO_RUN, ("total_steps",)),
    ],
    ids=["gait", "policy"],
)
def test_a_trained_run_whose_settings_dropped_their_budget_is_refused(tmp_path, source, dropped):
    """A run whose config's settings dropped its budget was admitted: a gait search
    claiming one training trial ranked on the study's track, a learner listed as an
    untrained reference. Its command still says what it was given, and a setting the
    command names must be there with that value (`admission.command_refusal`)."""
    run = _copy(tmp_path, source, "ppo" if source == PPO_RUN else "cem", os.path.basename(source))
    path = os.path.join(run, "config.json")
    config = json.loads(open(path, encoding="utf-8").read())
    for key in dropped:
        config["settings"].pop(key, None)
    with open(path, "w", encoding="utf-8") as f:
        json.dump(config, f)
    _edit_summary(
        run,
        lambda s: (
            s.update(evaluations=1, sim_steps=8)
            if source == GAIT_RUN
            else [s.pop(k, None) for k in ("env_steps", "evaluations")]
        ),
    )
    assert f"command says --{dropped[0]}=" in _board_refusal(run)


@pytest.mark.parametrize("distance", [99.0, -40.0, 32.5])
def test_an_in_sample_best_beyond_any_trials_reach_is_refused(tmp_path, distance):
    """summary.json's `in_sample` (shown as the in-sample best until verify tries it
    again) claimed 99 m and was shown; it is held to the distance any trial may claim."""
    run = _copy(tmp_path, GAIT_RUN, "cem", os.path.basename(GAIT_RUN))
    _edit_summary(run, lambda s: s.update(in_sample={"distance_m": distance, "fell": False}))
    assert "in_sample" in _board_refusal(run)


def test_a_configuration_of_picked_seeds_is_listed_not_ranked():
    """Shipping CEM's best 5 of its 10 seeds ranked the configuration 20 % above all 10,
    with no file changed. A configuration is ranked only on seeds 0, 1, ..., N−1; any other
    set is listed with the status `gapped_seeds`."""
    found, _ = leaderboard.find_runs(RUNS)
    cem = [r for r in found if r["method"] == "cem" and r["config"] == "K50_n0.8_e2"]
    assert sorted(r["seed"] for r in cem) == list(range(10))
    for seeds, status in (
        ({4, 8, 7, 1, 0}, leaderboard.GAPPED_STATUS),
        ({1, 2, 3, 4, 5}, leaderboard.GAPPED_STATUS),
        ({0, 1, 2, 3, 4}, "ranked"),
        (set(range(10)), "ranked"),
    ):
        (row,) = leaderboard.darwin_rows([r for r in cem if r["seed"] in seeds], 3)
        assert row["status"] == status, (seeds, row["status"])
        assert (row["rank"] == "") == (status != "ranked") and ("iqm_m" in row) == (
            status == "ranked"
        )


def _reparameterized(policy: exported.NumpyPolicy, rng) -> exported.NumpyPolicy:
    """The same network with each hidden layer's units in another order (the same function
    exactly) and its last layer nudged by 1e-7 of itself (helper-51's copy)."""
    arrays = policy.arrays()
    n = len(policy.layers)
    for i in range(n - 1):  # the units between layer i and layer i + 1
        order = rng.permutation(arrays[f"bias_{i}"].shape[0])
        arrays[f"kernel_{i}"] = arrays[f"kernel_{i}"][:, order]
        arrays[f"bias_{i}"] = arrays[f"bias_{i}"][order]
        arrays[f"kernel_{i + 1}"] = arrays[f"kernel_{i + 1}"][order, :]
    last = arrays[f"kernel_{n - 1}"]
    arrays[f"kernel_{n - 1}"] = last * (1 + 1e-7 * rng.standard_normal(last.shape))
    return exported.NumpyPolicy(arrays, policy.action_space)


@pytest.mark.parametrize(
    "source", ["ppo_mjx/darwin_walk/cpg_seed3", "ppo/darwin_walk/joints_seed0"]
)
def test_a_policy_with_its_hidden_units_reordered_and_nudged_is_a_copy(tmp_path, source):
    """A sixth outside attack: a PPO policy's hidden units permuted (the same function) and
    its last layer nudged by 1e-7, re-scored, was admitted as a new seed of its own
    configuration: no array matched its original's by position, and the nudge changed 243
    of 250 trials. Policies are compared by what they do as well
    (`copies.policy_responses`): the copy is one with its original, whatever its trials;
    two honest seeds are not."""
    original = os.path.join(RUNS, source)
    name = admission.EXPORTED
    copy = tmp_path / "copy"
    shutil.copytree(original, copy)
    policy = exported.NumpyPolicy.load(os.path.join(original, name))
    _reparameterized(policy, np.random.default_rng(0)).save(str(copy / name))
    trials = admission.read_trials(os.path.join(original, "trials.csv"))
    moved = [{**t, "distance_m": t["distance_m"] + 1.0} for t in trials]  # other trials
    theirs = copies.fingerprint(original, (name,), trials)
    ours = copies.fingerprint(str(copy), (name,), moved)
    assert not copies.same_trials(ours, theirs)
    assert copies.value_distance(ours.values, theirs.values) > copies.VALUE_RTOL  # by position
    assert copies.copy_of(ours, theirs) == "gait or policy"
    other = os.path.join(os.path.dirname(original), source.split("/")[-1][:-1] + "1")
    honest = copies.fingerprint(other, (name,), moved)
    assert copies.copy_of(honest, theirs) is None


@pytest.mark.parametrize(
    "key, value",
    [
        ("supply_window", True),
        ("supply_window", "1"),
        ("supply_window", " 1e0\n"),
        ("test_seeds", 50.0),
        ("test_seeds", True),
        ("trial_steps", "1000"),
    ],
)
def test_a_card_setting_of_another_json_kind_is_refused(tmp_path, key, value):
    """`true`, `"1"` and `" 1e0"` passed as the protocol's 1 s supply window (Python's
    `float` reads them all): a card's settings are held to their JSON kinds."""
    run = _copy(tmp_path, GAIT_RUN, "cem", os.path.basename(GAIT_RUN))
    path = os.path.join(run, "config.json")
    config = json.loads(open(path, encoding="utf-8").read())
    config["settings"][key] = value
    with open(path, "w", encoding="utf-8") as f:
        json.dump(config, f)
    assert key in _board_refusal(run)


def test_a_supply_window_spelled_as_a_json_number_is_admitted(tmp_path):
    """The protocol's window as a JSON integer or float is the same setting."""
    for value in (1, 1.0):
        run = _copy(tmp_path / str(value), GAIT_RUN, "cem", os.path.basename(GAIT_RUN))
        path = os.path.join(run, "config.json")
        config = json.loads(open(path, encoding="utf-8").read())
        config["settings"]["supply_window"] = value
        with open(path, "w", encoding="utf-8") as f:
            json.dump(config, f)
        assert admission.run_refusal(run) is None


def test_what_choosing_a_gait_simulated_counts_toward_its_track(tmp_path):
    """Choosing among 2,500 candidates on 50 validation seeds (70 times the study's
    simulation) ranked on the study's track: the track counts `validation_sim_steps`
    beyond the protocol's allowance with `sim_steps`; a gait search states it, no less than
    its config's validation takes."""
    run = _copy(tmp_path, GAIT_RUN, "cem", os.path.basename(GAIT_RUN))
    summary = json.loads(open(os.path.join(run, "summary.json"), encoding="utf-8").read())
    assert leaderboard.budget_track([summary]) == "study"
    assert leaderboard.budget_track([{**summary, "validation_sim_steps": 1_000_400_000}]) == (
        "over_4x"
    )
    allowed = leaderboard.VALIDATION_ALLOWANCE
    assert leaderboard.budget_track([{**summary, "validation_sim_steps": allowed}]) == "study"
    path = os.path.join(run, "config.json")
    config = json.loads(open(path, encoding="utf-8").read())
    config["settings"].update(validation_top=2500, validation_seeds=50)
    with open(path, "w", encoding="utf-8") as f:
        json.dump(config, f)
    assert "validation physics steps" in _board_refusal(run)  # claims the shipped run's
    _edit_summary(run, lambda s: s.pop("validation_sim_steps"))
    assert "choosing its gait" in _board_refusal(run)


@pytest.mark.parametrize(
    "source, flag",
    [(GAIT_RUN, "--population=100"), (GAIT_RUN, "--rounds=400"), (PPO_RUN, "--total_steps=4e7")],
)
def test_a_command_that_contradicts_its_budget_settings_is_refused(tmp_path, source, flag):
    """A run whose `command` trained 100 × 400 beside settings of 50 × 50 ranked on the
    study's track: the command's budget flags must be its settings' values."""
    run = _copy(tmp_path, source, "ppo" if source == PPO_RUN else "cem", os.path.basename(source))
    path = os.path.join(run, "config.json")
    config = json.loads(open(path, encoding="utf-8").read())
    key = flag[2:].split("=")[0]
    words = [w for w in config["command"].split() if not w.startswith(f"--{key}=")]
    config["command"] = " ".join(words + [flag])
    with open(path, "w", encoding="utf-8") as f:
        json.dump(config, f)
    assert f"command says {flag}" in _board_refusal(run)
    config["command"] = " ".join(words + [f"--{key}={config['settings'][key]}"])
    with open(path, "w", encoding="utf-8") as f:
        json.dump(config, f)
    assert admission.run_refusal(run) is None


@pytest.mark.parametrize(
    "flag",
    [
        "--eval_seeds 2",
        "-eval_seeds=2",
        "-eval_seeds 2",
        '"--eval_seeds=2"',
        "--eval_seeds\u00a0=2",
        "--flagfile=f.txt",
    ],
)
def test_every_spelling_of_a_budget_flag_is_read_as_absl_reads_it(tmp_path, flag):
    """A seventh reading (helper-52): `--eval_seeds 2`, `-eval_seeds=2`, a quoted flag and a
    flag file passed the command check beside settings of 1; `--eval_seeds=01` is 1."""
    run = _copy(tmp_path, GAIT_RUN, "cem", os.path.basename(GAIT_RUN))
    path = os.path.join(run, "config.json")
    config = json.loads(open(path, encoding="utf-8").read())
    words = [w for w in config["command"].split() if not w.startswith("--eval_seeds=")]
    config["command"] = " ".join(words + [flag])
    with open(path, "w", encoding="utf-8") as f:
        json.dump(config, f)
    assert "command" in _board_refusal(run)
    config["command"] = " ".join(words + ["--eval_seeds=01"])
    with open(path, "w", encoding="utf-8") as f:
        json.dump(config, f)
    assert admission.run_refusal(run) is None
