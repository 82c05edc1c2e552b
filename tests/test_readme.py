"""The README's quick start is what CI runs (two fenced shell blocks, the second in .ci/run), and
its Python blocks (the Python API, the minimal loop of "The estimator in your own simulation")
run as written; so do the "Your own robot" block (the shipped servicer7.urdf, built and run by
bash) and docs/fmus.md's fmpy recipe, parameter-defaults command, Pinocchio recipe (against
finite differences) and minimal loop (the README's, word for word)."""
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def quick_start_blocks():
    text = (ROOT / "README.md").read_text()
    section = text.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```bash\n(.*?)```", section, re.S)


def test_quick_start_has_exactly_two_shell_blocks():
    blocks = quick_start_blocks()
    assert len(blocks) == 2
    assert "spacerobot run" in blocks[0]
    assert "pytest" in blocks[1]


def test_ci_runs_the_readme_test_command():
    ci = (ROOT / ".ci" / "run").read_text()
    for line in quick_start_blocks()[1].strip().splitlines():
        assert line.strip() in ci


def python_block(section: str, path: Path = ROOT / "README.md") -> str:
    """The one fenced Python block of a section (``## <section>``) of a Markdown file."""
    text = path.read_text()
    part = text.split(f"## {section}\n", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```python\n(.*?)```", part, re.S)
    assert len(blocks) == 1, section
    return blocks[0]


def test_fmpy_recipe_runs_and_shows_the_fmu_message(planar_fmus, tmp_path):
    """docs/fmus.md's fmpy recipe, run as written (in a fresh process, from a folder holding
    build/planar/ as ``spacerobot build`` makes it)."""
    import shutil
    import subprocess
    import sys

    build = tmp_path / "build" / "planar"
    build.mkdir(parents=True)
    for path in planar_fmus.values():
        shutil.copy(path, build)
    p = subprocess.run([sys.executable, "-c", python_block("Using the FMUs from fmpy", ROOT / "docs" / "fmus.md")],
                       cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    line = next(x for x in p.stdout.splitlines() if x.startswith("target.m, target.Izz:"))
    m, izz = (float(x) for x in re.findall(r"[-+0-9.e]+", line.split(":", 1)[1]))
    assert abs(m - 250.0) / 250.0 < 1e-3            # the medium target, identified
    # the failing call: its status, and before it the FMU's own reason, printed by the logger
    assert "failed:" in p.stdout and "(error)" in p.stdout.split("failed:", 1)[1].lower()
    assert re.search(r"\[bad\] .*base\.m must be > 0 kg, got -1\.0", p.stdout), p.stdout


def test_python_api_block_runs(planar_fmus, tmp_path, monkeypatch):
    """The README's Python API block, with build_system given the session's FMUs (so that it
    does not rebuild them); every name it imports is public."""
    import spacerobot
    from spacerobot.system import ssd

    code = python_block("Python API")
    for names in re.findall(r"from spacerobot import ([\w, ]+)", code):
        assert {n.strip() for n in names.split(",")} <= set(spacerobot.__all__)
    monkeypatch.setattr(spacerobot, "build_system",
                        lambda robot, out: ssd.build_system(robot, out, fmus=planar_fmus))
    monkeypatch.chdir(tmp_path)
    scope: dict = {}
    exec(compile(code, "README.md", "exec"), scope)
    res, ident = scope["res"], scope["ident"]
    assert res.truth["target.m"] == 500.0 and (tmp_path / "large.csv").is_file()
    assert abs(res.final["target.m"] - 500.0) / 500.0 < 0.01
    assert ident.vector().shape == (20,)


# ---------------------------------------------------------------------------------------------
# the documented examples run as pasted
# ---------------------------------------------------------------------------------------------

def shell_block(section: str, path: Path = ROOT / "README.md") -> str:
    """The one fenced bash block of a section (``## <section>``) of a Markdown file."""
    text = path.read_text()
    part = text.split(f"## {section}\n", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```bash\n(.*?)```", part, re.S)
    assert len(blocks) == 1, section
    return blocks[0]


def _cli_env() -> dict:
    """The environment of a user's shell: the ``spacerobot`` console script of this Python's
    environment first on PATH."""
    import os
    import sys
    env = dict(os.environ, PYTHONWARNINGS="ignore")
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    return env


def test_own_robot_block_names_a_link_the_shipped_example_has():
    """The ee-link lookup (a wrong --ee such as tool0 for a file whose tip is tcp fails): every
    URDF and --ee of the block parse, through the command line's own argument handling."""
    import shlex
    from spacerobot.system import cli
    lines = [ln for ln in shell_block("Your own robot").strip().splitlines() if ln.strip()]
    assert [ln.split()[:2] for ln in lines] == [["spacerobot", "build"], ["spacerobot", "run"]]
    parser = cli.build_parser()
    for line in lines:
        args = parser.parse_args(shlex.split(line)[1:])
        assert (ROOT / args.robot).is_file(), args.robot
        key = cli.robot_key(type(args)(**dict(vars(args), robot=str(ROOT / args.robot))))
        assert key is not None and "servicer7" in key


@pytest.mark.slow
def test_own_robot_block_runs_as_pasted(tmp_path):
    """README "Your own robot": the bash block, run by bash in a folder laid out as the
    repository (the shipped URDF at the path the block names), builds servicer7's FMUs and runs
    them, printing the 20 estimates."""
    import shutil
    import subprocess
    block = shell_block("Your own robot")
    urdf = ROOT / "spacerobot" / "data" / "robots" / "servicer7.urdf"
    (tmp_path / "spacerobot" / "data" / "robots").mkdir(parents=True)
    shutil.copy(urdf, tmp_path / "spacerobot" / "data" / "robots")
    p = subprocess.run(["bash", "-e", "-c", block], cwd=tmp_path, capture_output=True,
                       text=True, timeout=1200, env=_cli_env())
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "build" / "servicer7" / "servicer7.ssp").is_file()
    assert "robot servicer7" in p.stdout
    from spacerobot import ESTIMATE_NAMES
    rows = [ln.split()[0] for ln in p.stdout.splitlines() if ln.split()]
    assert set(ESTIMATE_NAMES) <= set(rows)
    assert list((tmp_path / "results").glob("servicer7-*.csv"))


def test_parameter_defaults_command_of_docs_fmus(planar_fmus, tmp_path):
    """docs/fmus.md's command that lists every parameter with its default and unit (fmpy info
    does not), run by bash on a built estimator FMU; the defaults are the scenario's."""
    import shutil
    import subprocess
    from spacerobot.robots import scenario
    cmd = re.findall(r"```bash\n(python -c .*?)```", (ROOT / "docs" / "fmus.md").read_text(),
                     re.S)
    assert len(cmd) == 1
    (tmp_path / "build" / "planar").mkdir(parents=True)
    shutil.copy(planar_fmus["estimator"], tmp_path / "build" / "planar")
    p = subprocess.run(["bash", "-e", "-c", cmd[0]], cwd=tmp_path, capture_output=True,
                       text=True, timeout=300, env=_cli_env())
    assert p.returncode == 0, p.stderr
    listed = {ln.split()[0]: ln.split()[1:] for ln in p.stdout.splitlines()}
    guess = scenario("planar").guess
    assert float(listed["guess.target.m"][0]) == guess.target.mass
    assert listed["guess.target.m"][1] == "kg"
    assert listed["method"] == ["1"] and float(listed["lambda"][0]) == 1.0
    assert "base.r[1]" not in listed                          # inputs are not parameters


def test_pinocchio_recipe_of_docs_fmus():
    """docs/fmus.md's conversion of a Pinocchio free-flyer state into the estimator's inputs,
    against finite differences of Pinocchio's own integration of the configuration (which
    knows nothing of the recipe): base.v = dr/dt, base.a = d2r/dt2 (inertial), base.omega from
    dA/dt = A [omega]x, to 1e-6."""
    pin = pytest.importorskip("pinocchio")
    import numpy as np
    code = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "fmus.md").read_text(), re.S)
    recipe = [c for c in code if "def estimator_inputs" in c]
    assert len(recipe) == 1
    scope: dict = {}
    exec(compile(recipe[0], "docs/fmus.md", "exec"), scope)
    model = pin.buildModelFromUrdf(str(ROOT / "spacerobot" / "data" / "robots" /
                                       "servicer7.urdf"), pin.JointModelFreeFlyer())
    rng = np.random.default_rng(28)
    q0 = pin.neutral(model)
    q0[0:3] = rng.normal(size=3)
    quat = rng.normal(size=4)
    q0[3:7] = quat / np.linalg.norm(quat)
    q0[7:] = rng.uniform(-1.0, 1.0, size=model.nq - 7)
    v = rng.normal(size=model.nv)
    ddq = rng.normal(size=model.nv)

    def at(t):   # the configuration along v t + ddq t^2 / 2: velocity v, acceleration ddq
        q = pin.integrate(model, q0, v * t + 0.5 * ddq * t * t)
        return q[0:3].copy(), pin.XYZQUATToSE3(q[:7]).rotation
    h = 1e-4
    (rm, Am), (r0, A0), (rp, Ap) = at(-h), at(0.0), at(h)
    got = scope["estimator_inputs"](q0, v, ddq)
    assert np.allclose(got["base.r"], r0, atol=1e-12)
    assert np.allclose(got["base.A"], A0, atol=1e-12)
    assert np.allclose(got["base.v"], (rp - rm) / (2 * h), atol=1e-6)
    assert np.allclose(got["base.a"], (rp - 2 * r0 + rm) / h ** 2, atol=1e-5)
    W = A0.T @ (Ap - Am) / (2 * h)                               # [omega_B]x
    assert np.allclose(got["base.omega"], [W[2, 1], W[0, 2], W[1, 0]], atol=1e-6)
    # the confusion the docs warn of: Pinocchio's own ddq[0:3] is not the inertial acceleration
    assert not np.allclose(ddq[0:3], (rp - 2 * r0 + rm) / h ** 2, atol=1e-2)


def test_minimal_loop_runs_as_written(planar_fmus, tmp_path):
    """The README's "The estimator in your own simulation" block (docs/fmus.md's "A minimal
    loop in your own simulator" is the same text), run as written in a fresh process from a
    folder holding build/planar/, feeds the estimator FMU from the plant without FMI and
    prints the target's mass and inertia, within 0.01 % of the scenario's truth as the text
    says."""
    import shutil
    import subprocess
    import sys
    from spacerobot.robots import scenario
    code = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "fmus.md").read_text(), re.S)
    loop = [c for c in code if "def sample(y)" in c]
    assert loop == [python_block("The estimator in your own simulation")]
    (tmp_path / "build" / "planar").mkdir(parents=True)
    shutil.copy(planar_fmus["estimator"], tmp_path / "build" / "planar")
    p = subprocess.run([sys.executable, "-c", loop[0]], cwd=tmp_path, capture_output=True,
                       text=True, timeout=600, env=_cli_env())
    assert p.returncode == 0, p.stderr
    m, izz = (float(x) for x in re.findall(r"= ([-+0-9.e]+)", p.stdout))
    target = scenario("planar", "medium").target
    assert abs(m - target.mass) / target.mass < 1e-4
    assert abs(izz - target.inertia[2]) / target.inertia[2] < 1e-4
