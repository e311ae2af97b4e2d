"""`drake-tooluse --version`: one line, exit 0."""

import importlib.metadata
import platform
import subprocess
import sys

from drake_tooluse import __version__
from drake_tooluse.cli import main


def test_version_is_one_line_of_the_package_drake_and_python(capsys):
    assert main(["--version"]) == 0
    out = capsys.readouterr().out
    drake = importlib.metadata.version("drake")
    assert out == (
        f"drake-tooluse {__version__} (Drake {drake}, Python {platform.python_version()})\n"
    )


def test_version_from_the_console_exits_0_without_importing_drake():
    code = (
        "import sys\nfrom drake_tooluse.cli import main\nc = main(['--version'])\n"
        "print(c, 'pydrake' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.stdout.splitlines()[-1] == "0 False", out.stdout + out.stderr
