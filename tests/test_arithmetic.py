"""The arithmetic a process computes with (NumPy's BLAS kernel and SIMD loops) and its pinning
(:mod:`windnav.experiments.arithmetic`)."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys

import pytest

from windnav.experiments import arithmetic as ar

X86_OPENBLAS = pytest.mark.skipif(
    platform.machine() != "x86_64" or not (ar.blas_kernel() or "").startswith("OpenBLAS")
    or ar.numpy_simd() is None, reason="pins OpenBLAS's kernels and NumPy's x86 SIMD targets")


def run(env: dict) -> dict:
    """The arithmetic of a new process under ``env``."""
    out = subprocess.run(
        [sys.executable, "-c", "import json; from windnav.experiments.arithmetic import "
         "arithmetic; print(json.dumps(arithmetic()))"],
        capture_output=True, text=True, check=True, env={**os.environ, **env})
    return json.loads(out.stdout)


def test_arithmetic_names_the_blas_kernel_and_the_numpy_targets():
    got = ar.arithmetic()
    assert list(got) == ["blas_kernel", "numpy_simd"]
    assert got == run({})
    if got["numpy_simd"] not in (None, "baseline"):
        from numpy._core._multiarray_umath import __cpu_dispatch__

        assert set(got["numpy_simd"].split()) <= set(__cpu_dispatch__)


@X86_OPENBLAS
def test_a_record_of_older_kernels_and_loops_is_pinned_and_the_pin_holds():
    """A record flown under OpenBLAS's Nehalem kernels and NumPy's baseline loops (any x86-64
    CPU runs them): the environment it gives makes a new process report that arithmetic."""
    want = {"blas_kernel": "OpenBLAS Nehalem", "numpy_simd": "baseline"}
    env, line = ar.pinned_environment(want)
    assert env["OPENBLAS_CORETYPE"] == "Nehalem" and "'OpenBLAS Nehalem'" in line
    higher = ar.numpy_simd().split() if ar.numpy_simd() != "baseline" else []
    assert env.get("NPY_DISABLE_CPU_FEATURES", "").split() == higher
    assert run(env) == want
    # this process's own arithmetic needs no pin; a record without the fields pins nothing
    assert ar.pinned_environment(ar.arithmetic())[0] == {}
    assert ar.pinned_environment({"scenario_id": "quick/m00/w00/p0"}) == ({}, "")


@X86_OPENBLAS
@pytest.mark.parametrize("want, why", [
    ({"blas_kernel": "OpenBLAS NoSuchCore"}, "reports"),  # OpenBLAS falls back to its own pick
    ({"blas_kernel": "MKL SkylakeX"}, "only OpenBLAS kernels"),
    ({"numpy_simd": "X86_V3 X86_V4 AVX512_ICL AVX512_SPR NO_SUCH"}, "cannot run NumPy's"),
])
def test_an_arithmetic_this_machine_cannot_run_is_refused_with_the_reason(want, why):
    env, line = ar.pinned_environment(want)
    assert env is None and why in line


def test_the_portable_arithmetic_is_avx2():
    assert ar.PORTABLE == {"blas_kernel": "OpenBLAS Haswell", "numpy_simd": "X86_V3"}
    env, line = ar.portable_environment()
    if env is not None:  # a machine with AVX2 and OpenBLAS: the pin holds
        assert run(env) == ar.PORTABLE
    else:
        assert line.startswith("this machine cannot run the portable arithmetic")


@X86_OPENBLAS
def test_nearest_pins_the_rest_of_an_arithmetic_whose_numpy_targets_this_cpu_lacks():
    """A record naming a NumPy target this machine lacks (an Intel Xeon's AVX512_SPR on an AMD
    EPYC) is refused as it stands, and with ``nearest`` pinned without that target: its BLAS
    kernel and the targets this machine has, which a new process then reports."""
    from numpy._core._multiarray_umath import __cpu_features__

    if not __cpu_features__.get("X86_V3"):
        pytest.skip("needs a CPU with AVX2 (NumPy's X86_V3)")
    want = {"blas_kernel": "OpenBLAS Nehalem", "numpy_simd": "X86_V3 NO_SUCH"}
    env, line = ar.pinned_environment(want)
    assert env is None and "cannot run NumPy's" in line
    env, line = ar.pinned_environment(want, nearest=True)
    assert env["OPENBLAS_CORETYPE"] == "Nehalem"
    assert "without NumPy's NO_SUCH loops, which this machine cannot run" in line
    assert run(env) == {"blas_kernel": "OpenBLAS Nehalem", "numpy_simd": "X86_V3"}
    # this machine's own arithmetic and a target it lacks: nothing to pin, and said so
    own = ar.arithmetic()
    env, line = ar.pinned_environment(
        {**own, "numpy_simd": f"{own['numpy_simd']} NO_SUCH"}, nearest=True)
    assert env == {} and "without NumPy's NO_SUCH loops" in line
    assert ar.pinned_environment(own, nearest=True) == ({}, ar.pinned_environment(own)[1])


def test_process_environment_adds_variables_for_the_block_and_restores_them(monkeypatch):
    monkeypatch.setenv("WINDNAV_TEST_KEPT", "before")
    monkeypatch.delenv("WINDNAV_TEST_NEW", raising=False)
    with ar.process_environment({"WINDNAV_TEST_KEPT": "pinned", "WINDNAV_TEST_NEW": 1}):
        out = subprocess.run([sys.executable, "-c", "import os; print(os.environ["
                              "'WINDNAV_TEST_KEPT'], os.environ['WINDNAV_TEST_NEW'])"],
                             capture_output=True, text=True, check=True)
        assert out.stdout.split() == ["pinned", "1"]  # a process started in the block
    assert os.environ["WINDNAV_TEST_KEPT"] == "before" and "WINDNAV_TEST_NEW" not in os.environ
    with pytest.raises(KeyError), ar.process_environment({"WINDNAV_TEST_NEW": "x"}):
        raise KeyError("restored on an exception too")
    assert "WINDNAV_TEST_NEW" not in os.environ
