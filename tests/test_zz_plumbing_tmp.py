import subprocess, sys
import pytest

CODE = "from cosserat_fsi import compat; from mpi4py import MPI; c=MPI.COMM_WORLD; print(c.allreduce(1))"

def test_compat_imports():
    from cosserat_fsi import compat
    print(compat.DOLFINX_VERSION)

def test_mpirun_subprocess(mpirun):
    out = subprocess.run(mpirun(2) + [sys.executable, "-c", CODE], env=mpirun.env,
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.count("2") == 2, out.stdout

def test_mpirun_run(mpirun):
    out = mpirun.run(2, [sys.executable, "-c", CODE])
    assert out.returncode == 0, out.stderr
    assert out.stdout.count("2") == 2, out.stdout

@pytest.mark.mpi
def test_mpi_size(mpi_comm):
    assert mpi_comm.allreduce(1) == mpi_comm.size
