"""`import octowrap` leaves numpy alone until an array crosses."""

import subprocess
import sys


def run_python(code: str) -> str:
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    return run.stdout.strip()


def test_import_does_not_import_numpy():
    out = run_python(
        "import sys, octowrap\n"
        "print('numpy' in sys.modules, sorted(m for m in sys.modules if m.startswith('octowrap')))\n"
        "octowrap.open_mrq  # attribute access alone imports nothing\n"
        "print('numpy' in sys.modules)\n"
    )
    assert out.splitlines() == ["False ['octowrap', 'octowrap._octowrap']", "False"]


def test_numpy_is_imported_when_an_array_crosses(tmp_path):
    (tmp_path / "p.xyz").write_text("0 0 0\n1 0 0\n0 1 0\n")
    out = run_python(
        "import sys, octowrap\n"
        f"c = octowrap.read({str(tmp_path / 'p.xyz')!r})\n"
        "print('numpy' in sys.modules, type(c.points).__module__, c.points.shape)\n"
    )
    assert out == "True numpy (3, 3)"
    out = run_python(
        "import sys, octowrap\n"
        "try:\n"
        "    octowrap.validate([[0, 0, 0]], None)\n"
        "except ValueError as e:\n"
        "    print('numpy' in sys.modules, e)\n"
    )
    assert out.startswith("True vertices must be a numpy array")
