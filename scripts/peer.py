"""Peers the benches compare against, installed into this Python when missing."""

import importlib
import subprocess
import sys


def need(module, spec):
    """Whether `module` imports, after `pip install spec` into this Python when it did not.
    Says what it installs; False when pip fails or the module still does not import."""
    try:
        importlib.import_module(module)
        return True
    except ImportError:
        pass
    print(f"installing {spec} into {sys.executable} ...", flush=True)
    r = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--disable-pip-version-check", spec]
    )
    if r.returncode != 0:
        return False
    importlib.invalidate_caches()
    try:
        importlib.import_module(module)
        return True
    except ImportError:
        return False
