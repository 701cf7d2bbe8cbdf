# Two commands on a fresh machine with Python 3.11, make and pip: `make run` and `make test`.
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: run test bench clean

$(PY):
	$(PYTHON) -m venv $(VENV)

# Installs against constraints.txt, the versions the suite was last run with, so a new
# release upstream cannot break a clean install silently.
$(STAMP): pyproject.toml constraints.txt | $(PY)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -c constraints.txt -e '.[dev,cluster]'
	touch $(STAMP)

run: $(STAMP)
	$(VENV)/bin/optdesign analyze problems/sharkov2022.yaml
	$(VENV)/bin/optdesign solve problems/sharkov2022_disc.yaml --out results/sharkov2022_disc

test: $(STAMP)
	$(PY) -m pytest -q

bench: $(STAMP)
	$(PY) benchmarks/solve_vs_peers.py

clean:
	rm -rf $(VENV) .pytest_cache results/*/
