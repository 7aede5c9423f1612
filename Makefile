# depsim: two commands set up a fresh machine.
#   make demo   create .venv, install, compile examples/intelsat5.dep to C and run it
#   make test   create .venv, install, run the test suite
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test install clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test,studies]'
	touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	mkdir -p results
	$(BIN)/depsim check examples/intelsat5.dep
	$(BIN)/depsim run examples/intelsat5.dep --target c -o results/intelsat5.csv \
		--summary results/intelsat5.json --plot results/intelsat5.png

# pytest exits 5 when it collects nothing: an empty suite is a failure, not a pass.
# -n auto: one worker per core (pytest-xdist), each test module on one worker (loadscope), so
# that a module's compiled models are built once.
test: $(STAMP)
	$(BIN)/python -m pytest -n auto --dist loadscope; status=$$?; \
	if [ $$status -eq 5 ]; then echo "error: no tests were collected" >&2; exit 1; fi; \
	exit $$status

clean:
	rm -rf $(VENV) results build *.egg-info
