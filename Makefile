# Every target makes .venv itself when it is missing (fast when present).
PY := .venv/bin/python
STAMP := .venv/.installed
export MUJOCO_GL ?= egl

.PHONY: demo test bench lint clean

$(STAMP): pyproject.toml
	test -x $(PY) || python3 -m venv .venv
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

demo: $(STAMP)
	mkdir -p out/demo
	.venv/bin/cell run scenarios/sort.toml --report out/demo/report.json --replay out/demo/replay.rrd

test: $(STAMP)
	$(PY) -m pytest -q

bench: $(STAMP)
	bash bench/run_all.sh

lint: $(STAMP)
	.venv/bin/ruff check .

clean:
	rm -rf out .pytest_cache
