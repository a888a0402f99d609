"""torch's CPU kernels for training and serving: the ones every x86-64 processor computes alike.

torch chooses its CPU kernels by the processor it runs on: ATen's vectorised loops by the widest
instruction set there is (AVX-512, AVX2 or neither), oneMKL's matrix products likewise. Their
sums round differently, so the same command, with the same frames, trained weights that differed
in every array from one processor to another (after one epoch of ng-ransac a held-out loss of
0.037274040 under AVX-512 kernels, 0.037274048 under ATen's baseline ones). Training therefore
asks for the kernels every x86-64 processor runs: ATen's baseline loops
(``ATEN_CPU_CAPABILITY=default``) and oneMKL's reproducible branch for Intel and compatible
processors alike, SSE2 without its approximate reciprocals (``MKL_CBWR=COMPATIBLE``, oneMKL's
conditional numerical reproducibility). Weights trained so are the same, bit for bit, on any
x86-64 processor with the same torch wheel and thread count (other architectures compute
otherwise). The cost is speed: ng-ransac's epochs take about 35 % longer than with AVX-512
kernels, ``learned``'s about 20 %.

Serving a policy is the same story: a navigator drives on its own actions, so one action that
differs in its last bit moves the whole episode, and the shipped PPO policy scored the
navigation board's episodes differently on an AVX-512 processor than on the one that made the
board. :func:`~azgym.nav.policy_file.load_policy` therefore pins the kernels too, and the
board's episodes repeat on any x86-64 processor.

Both settings are read when torch runs its first operation in a process, so
:func:`pin_kernels` comes before that (the training functions and the policy loader call it
first). A process that has already run torch operations keeps the processor's own kernels; a
training run then says so in its manifest and model card (``kernels``), as weights that repeat
only on a like processor, and the policy loader warns that the episodes it drives repeat only on
a like processor.
"""

from __future__ import annotations

import os

__all__ = ["PORTABLE", "PORTABLE_KERNELS", "describe_kernels", "pin_kernels"]

PORTABLE_KERNELS = {"ATEN_CPU_CAPABILITY": "default", "MKL_CBWR": "COMPATIBLE"}
"""The environment that asks torch (ATen, oneMKL) for the kernels every x86-64 processor runs."""
PORTABLE = "portable"
"""What a run computed with, as its manifest records it, when the portable kernels were used."""


def pin_kernels() -> str:
    """Ask for the portable kernels in this process; say which kernels torch computes with.

    Returns:
        :data:`PORTABLE`, or ``"native AVX512"`` (the processor's own kernels, named by ATen's
        capability) when torch had already chosen its kernels in this process.
    """
    os.environ.update(PORTABLE_KERNELS)
    import torch

    capability = torch.backends.cpu.get_cpu_capability()
    return PORTABLE if capability == "DEFAULT" else f"native {capability}"


def describe_kernels(kernels: str) -> str:
    """What a card says of the kernels :func:`pin_kernels` named.

    ``portable CPU kernels``, or the processor's own, whose results repeat only on a like one.
    """
    return ("portable CPU kernels" if kernels == PORTABLE else
            f"{kernels} CPU kernels: the results repeat only on a like processor")
