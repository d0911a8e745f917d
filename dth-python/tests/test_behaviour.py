"""What a Python user expects of long calls: Ctrl-C stops them, other threads run meanwhile,
and repeated calls leak nothing."""

import gc
import os
import signal
import subprocess
import sys
import textwrap
import threading

import numpy as np

import dth

# A run long enough never to finish by itself in these tests (10^9 steps of an oscillator).
# The child installs Python's own Ctrl-C handler itself: a process that a non-interactive
# shell started in the background (as CI runners and `cmd &` in a script do) inherits SIGINT
# *ignored*, and Python then installs no KeyboardInterrupt handler, so the signal would never
# reach the run and this test would hang instead of testing the extension. "started" is
# printed inside the `try`, so a signal that lands before the call is caught as well.
LONG_RUN = textwrap.dedent(
    """
    import signal, sys, dth
    signal.signal(signal.SIGINT, signal.default_int_handler)
    h = dth.Hamiltonian("p1^2/2 + q1^2/2")
    try:
        print("started", flush=True)
        dth.integrate(h, [1.0, 0.0], dtau=0.01, steps=10**9, every=10**9)
    except KeyboardInterrupt:
        print("interrupted", flush=True)
        sys.exit(3)
    print("finished", flush=True)
    """
)


def test_ctrl_c_interrupts_a_long_integration():
    child = subprocess.Popen(
        [sys.executable, "-c", LONG_RUN],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)},
    )
    assert child.stdout is not None
    assert child.stdout.readline().strip() == "started"
    # Let it enter the Rust loop, then interrupt as Ctrl-C does.
    threading.Event().wait(0.3)
    child.send_signal(signal.SIGINT)
    try:
        out, err = child.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        child.kill()
        raise AssertionError("the run did not stop on SIGINT")
    assert child.returncode == 3, (out, err)
    assert "interrupted" in out


def test_other_python_threads_run_during_an_integration():
    # The integration releases the GIL: a Python thread counting beside it makes progress
    # while it runs. With the GIL held, the counter could not move between the two reads,
    # which the calling thread makes just before and just after the call.
    h = dth.Hamiltonian("p1^2/2 + q1^2/2")
    counter = [0]
    done = threading.Event()

    def ticker():
        while not done.is_set():
            counter[0] += 1

    thread = threading.Thread(target=ticker)
    thread.start()
    before = counter[0]
    s = dth.integrate(h, [1.0, 0.0], dtau=0.01, steps=300_000, every=10**9)
    during = counter[0] - before
    done.set()
    thread.join()
    assert s.completed
    assert during > 1000


def test_ten_thousand_calls_leak_no_references():
    h = dth.systems.kepler()
    z = np.array([0.5, 0.0, 0.0, 1.2])
    for _ in range(100):  # warm up caches
        h.gradient(z)
        dth.integrate(h, z, dtau=0.05, steps=3)
    gc.collect()
    before = (sys.getrefcount(h), sys.getrefcount(z), len(gc.get_objects()))
    for _ in range(10_000):
        h.value(z)
        h.gradient(z)
        h.hessian(z)
        h.psi(z)
        s = dth.integrate(h, z, dtau=0.05, steps=3)
        del s
    gc.collect()
    after = (sys.getrefcount(h), sys.getrefcount(z), len(gc.get_objects()))
    assert after[:2] == before[:2]
    # Objects tracked by the collector: unchanged up to a little bookkeeping noise.
    assert abs(after[2] - before[2]) < 100


def test_errors_leak_no_references():
    h = dth.systems.kepler()
    z = [0.5, 0.0, 0.0]
    gc.collect()
    before = sys.getrefcount(h)
    for _ in range(2_000):
        try:
            h.value(z)
        except ValueError:
            pass
        try:
            dth.Hamiltonian("p1^2 + * q1")
        except dth.HamiltonianError:
            pass
    gc.collect()
    assert sys.getrefcount(h) == before
