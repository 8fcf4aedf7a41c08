"""The command line in a child process, for the tests that run, kill or time out a command:
its environment, waiting for a line of its progress, and its outcome within a time limit."""

import os
import selectors
import signal
import subprocess
import time

import pytest

from benchmarks.fem import mpirun_environment


def command_environment() -> dict:
    """This environment without an MPI launcher's variables (the child is a singleton, or starts
    its own ``mpirun``)."""
    env = mpirun_environment()
    env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    return env


def wait_for_line(process, text: str, seconds: float) -> str:
    """Read the child's stderr until a line containing ``text``; fail after ``seconds``."""
    selector = selectors.DefaultSelector()
    selector.register(process.stderr, selectors.EVENT_READ)
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if selector.select(timeout=1.0):
            line = process.stderr.readline()
            if not line:
                break
            if text in line:
                return line
    pytest.fail(f"no line with {text!r} on the child's stderr within {seconds} s")


def command_outcome(command: list[str], cwd, timeout: float) -> tuple[int, str] | None:
    """Exit status and stderr of ``command``, or None if it did not end within ``timeout``
    seconds (then it is stopped with its children: TERM, which mpirun passes on, then KILL)."""
    process = subprocess.Popen(command, cwd=cwd, env=command_environment(), text=True,
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                               start_new_session=True)
    try:
        return process.wait(timeout), process.stderr.read()
    except subprocess.TimeoutExpired:
        process.terminate()
        try:
            process.wait(20)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
        return None
    finally:
        process.stderr.close()
