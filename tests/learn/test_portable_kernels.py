"""Training computes with the CPU kernels every x86-64 processor runs alike (azgym.torch_kernels).

torch chooses its kernels by the processor (ATen's AVX-512, AVX2 or baseline loops, oneMKL's
branches), and they round differently: the same command trained other weights on another
processor. Here two processors are emulated by limiting what torch may use
(``ATEN_CPU_CAPABILITY``, ``MKL_ENABLE_INSTRUCTIONS``): each model's command must train the very
same weight arrays under both, and say in its manifest that it used the portable kernels.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from azgym.localize.learned.weights import load_weights

pytest.importorskip("torch", reason="training needs pip install torch==2.13.0")

PROCESSORS = {"avx2": {"ATEN_CPU_CAPABILITY": "avx2", "MKL_ENABLE_INSTRUCTIONS": "AVX2"},
              "baseline": {"ATEN_CPU_CAPABILITY": "default",
                           "MKL_ENABLE_INSTRUCTIONS": "SSE4_2"}}
"""Two processors as torch would see them (on one without AVX2 both are the baseline)."""


def run(code: str, processor: str, timeout: float = 240) -> subprocess.CompletedProcess[str]:
    """Python ``code`` in a fresh process that sees ``processor``'s instruction sets."""
    env = {key: value for key, value in os.environ.items()
           if key not in ("ATEN_CPU_CAPABILITY", "MKL_CBWR", "MKL_ENABLE_INSTRUCTIONS")}
    result = subprocess.run([sys.executable, "-c", code], env={**env, **PROCESSORS[processor]},
                            capture_output=True, text=True, timeout=timeout)
    assert result.returncode == 0, result.stderr[-2000:]
    return result


@pytest.mark.slow
@pytest.mark.parametrize("model", ["ng-ransac", "learned"])
def test_the_command_trains_the_same_weights_on_every_processor(model, tmp_path):
    weights = {}
    for processor in PROCESSORS:
        out = tmp_path / processor
        run("from azgym.cli import main; raise SystemExit(main(['train', 'localizer', "
            f"'--model', '{model}', '--out', r'{out}', '--layouts', '2', "
            "'--frames-per-layout', '10', '--epochs', '2']))", processor)
        arrays, manifest = load_weights(out / f"{model}.npz", model)
        assert manifest["training"]["kernels"] == "portable"
        weights[processor] = arrays
    differing = [name for name, array in weights["avx2"].items()
                 if not np.array_equal(array, weights["baseline"][name])]
    assert differing == []


def test_a_process_that_already_ran_torch_says_its_kernels_are_the_processor_s_own():
    ask = "from azgym.torch_kernels import pin_kernels; print(pin_kernels())"
    assert run(ask, "avx2", timeout=120).stdout.split() == ["portable"]
    late = run("import torch; torch.relu(torch.ones(64)); "
               f"print(torch.backends.cpu.get_cpu_capability()); {ask}", "avx2", timeout=120)
    chosen, kernels = late.stdout.splitlines()
    assert kernels == ("portable" if chosen == "DEFAULT" else f"native {chosen}")
