"""The README's quick start is what CI runs: two fenced shell blocks, the second in .ci/run."""
import re
from pathlib import Path

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
