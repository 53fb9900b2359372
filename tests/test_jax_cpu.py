"""The installed JAX finishes what MJX asks of XLA's CPU runtime under `vmap`.

MJX factorizes mass matrices and its Newton solver's Hessians with `cho_factor`; under
`vmap` each becomes one batched LAPACK call (`lapack_spotrf_ffi`), and independent ones may
run at once on XLA's CPU thread pool. jaxlib 0.10.0-0.11.0 splits such a call over that
same pool and waits for the pieces from inside it: with every pool thread waiting, nothing
runs the pieces, and the program stops at 0 % CPU for good (on the 2-core development
machine: `benchmarks/bench_mjx.py --batches=256` and Brax's PPO on 64 robots;
docs/decisions.md#jax-versions). jaxlib 0.9.2 and 0.11.1+ compute the batch in the calling
thread; setup.py's extras exclude the others.

The check runs the smallest program found to stop under jaxlib 0.10.2 (3 of 3 tries, each
killed after 30 s; jaxlib 0.9.2: 1.8 s) in a child process, since a stopped XLA call
cannot be interrupted from Python.
"""

import os
import subprocess
import sys
import textwrap

import pytest

pytestmark = pytest.mark.slow  # JAX programs in child processes

pytest.importorskip("jax")

# Four independent batched factorizations per loop step, each after an elementwise kernel
# large enough for XLA to split over the pool's threads (a finished split wakes the next
# thunk on a pool thread, which is how the factorizations come to occupy all of them).
_PROGRAM = textwrap.dedent(
    """
    import jax
    import jax.numpy as jnp

    BATCH, SIZE, REPEATS, CALLS = 256, 26, 200, 4

    def spd(key):
        a = jax.random.normal(key, (BATCH, SIZE, SIZE), jnp.float32)
        return a @ jnp.swapaxes(a, -1, -2) + SIZE * jnp.eye(SIZE, dtype=jnp.float32)

    @jax.jit
    def factorizations(mats):
        def body(i, mats):
            return tuple(
                x + 1e-3 * jnp.linalg.cholesky(x + 1e-6 * jnp.sin(x) * jnp.cos(x))
                for x in mats
            )
        return jax.lax.fori_loop(0, REPEATS, body, mats)

    mats = tuple(spd(jax.random.key(k)) for k in range(CALLS))
    out = jax.block_until_ready(factorizations(mats))
    assert all(bool(jnp.all(jnp.isfinite(x))) for x in out)
    print("finished", jax.__version__)
    """
)
TIMEOUT_S = 120  # jaxlib 0.9.2 on 2 cores: about 5 s with the import; stopped runs never end


def test_batched_cholesky_on_the_cpu_thread_pool_finishes():
    try:
        done = subprocess.run(
            [sys.executable, "-c", _PROGRAM],
            capture_output=True,
            text=True,
            timeout=TIMEOUT_S,
            env={**os.environ, "JAX_PLATFORMS": "cpu"},
        )
    except subprocess.TimeoutExpired:
        import jax

        pytest.fail(
            f"jax {jax.__version__}: batched Cholesky factorizations did not finish in "
            f"{TIMEOUT_S} s (the jaxlib 0.10.0-0.11.0 thread-pool deadlock; setup.py excludes "
            "those releases)"
        )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.startswith("finished")
