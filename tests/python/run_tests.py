"""Runs the Python module's tests (this folder) with pytest, first saying plainly which module is
missing when one is. CTest runs it as: PYTHON run_tests.py MODULE_DIR SSRFLEET_COMMAND."""

import importlib
import os
import sys

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
here = os.path.dirname(os.path.abspath(__file__))
if len(sys.argv) != 3:
    sys.exit("usage: run_tests.py MODULE_DIR SSRFLEET_COMMAND (the build's python/ folder and its ssrfleet)")
module_dir, command = sys.argv[1], sys.argv[2]
sys.path.insert(0, module_dir)
os.environ["PYTHONPATH"] = module_dir + os.pathsep + os.environ.get("PYTHONPATH", "")
os.environ["SSRFLEET_CLI"] = command

missing = []
for name, package in (("numpy", "python3-numpy"), ("pytest", "python3-pytest")):
    try:
        importlib.import_module(name)
    except ImportError:
        missing.append(f"{name} (apt-get install {package})")
if missing:
    sys.exit(f"{sys.executable}: missing Python module(s): {', '.join(missing)}; scripts/setup-debian.sh installs them")
try:
    import ssrfleet  # noqa: F401
except ImportError as e:
    sys.exit(f"cannot import ssrfleet from {module_dir}: {e} (build the target ssrfleet_python)")

import pytest  # noqa: E402

sys.exit(pytest.main([here, "-q", "-p", "no:cacheprovider", "--rootdir", here]))
