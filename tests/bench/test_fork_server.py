"""The workers' fork server warms up the run's own built-ins, never a plug-in."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import pytest

from azgym.bench.run.contenders import (
    DEFAULT_SPECS,
    REPAIR_TRACKER,
    builtins_to_warm,
    contender,
    contenders_named,
    warm_up,
)
from azgym.jit import PRECOMPILE_SWITCH


def labels(contenders):
    return [c.label for c in contenders]


def test_the_reference_comes_first_and_plug_ins_are_left_out():
    run = [contender("lsq"), contender("tests/mine.py:Mine"), contender("ransac-weighted"),
           contender("ransac")]
    assert labels(builtins_to_warm(run)) == ["ransac", "lsq", "ransac-weighted"]


@pytest.mark.parametrize("given", [None, "not json", '{"ransac": 1}', '["ransac", 3]', "[[]]"])
def test_without_a_list_of_labels_the_defaults_are_warmed(given):
    assert labels(contenders_named(given)) == [*DEFAULT_SPECS, REPAIR_TRACKER]


def test_a_list_names_its_contenders_in_order_an_unreadable_label_left_out():
    given = json.dumps(["triplet", "evil.py:Evil", "ransac:a=1,a=2", "mex-coarse", REPAIR_TRACKER])
    assert labels(contenders_named(given)) == ["triplet", "evil.py:Evil", "mex-coarse",
                                               REPAIR_TRACKER]
    assert contenders_named("[]") == []


def test_the_warm_up_never_imports_a_plug_in(tmp_path):
    # It runs in the caller's process (the runner, the fork server), where the truth may be.
    marker = tmp_path / "imported"
    plugin = tmp_path / "planted.py"
    plugin.write_text(f"open({str(marker)!r}, 'w').close()\nclass Planted: pass\n")
    warm_up([contender(f"{plugin}:Planted"), contender("azgym_evil_module:Class")])
    assert not marker.exists()


PROBE = """
import os, sys
from azgym.bench.run.processes import WARM_UP

def sees_the_list():
    sys.exit(3 if WARM_UP in os.environ else 0)
"""

FORK_SERVER = """
import os, sys
from azgym.bench.run.processes import WARM_UP, context, start_fork_server
from fork_probe import sees_the_list

start_fork_server(["triplet", sys.argv[1] + ":Planted"])
assert WARM_UP not in os.environ, "the caller's environment keeps the list"
worker = context().Process(target=sees_the_list)  # forked once the server has warmed up
worker.start()
worker.join()
print(worker.exitcode)
"""


@pytest.mark.slow
def test_the_fork_server_compiles_the_named_built_in_only_and_never_imports_a_plug_in(tmp_path):
    # An empty kernel cache and no kernels from the installation: whatever the server warms up,
    # it compiles, and numba writes the kernel's index to the cache.
    marker = tmp_path / "imported"
    plugin = tmp_path / "planted.py"
    plugin.write_text(f"open({str(marker)!r}, 'w').close()\nclass Planted: pass\n")
    (tmp_path / "fork_probe.py").write_text(textwrap.dedent(PROBE))
    kernels = tmp_path / "kernels"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(kernels), PRECOMPILE_SWITCH: "0",
           "PYTHONPATH": os.pathsep.join([str(tmp_path), *sys.path])}
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(FORK_SERVER), str(plugin)],
                          capture_output=True, text=True, timeout=300, env=env, check=True)
    assert done.stdout.strip() == "0", "a worker inherited the list"
    compiled = {path.name.split("-")[0] for path in kernels.rglob("*.nbi")}
    assert "triplet._best_triplet" in compiled
    assert not any(name.startswith("ransac.") for name in compiled), sorted(compiled)
    assert not marker.exists()
