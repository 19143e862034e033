# ReScene: `make help` lists the targets. Every target installs what it needs first.
SHELL := /bin/bash
VENV ?= .venv
PY := $(VENV)/bin/python
RESCENE := $(VENV)/bin/rescene
STAMP := $(VENV)/.installed
DEBIAN_PACKAGES := libusb-1.0-0 libgomp1 libgl1 nodejs chromium postgresql
# nodejs runs the Khronos glTF validator; chromium is the headless browser the report tests drive;
# postgresql is the database of a Prefect server that several workers share (make server-postgres, make drills)
DEMO_DIR ?= demo
PRESET ?= standard
SEED ?= 0
SEEDS ?= 0-4
BENCH_DIR ?= bench
PREFECT_API_URL ?= http://127.0.0.1:4200/api
POOL ?= rescene-local
PG_DIR ?= $(abspath .postgres)
PG_PORT ?= 5432
HEARTBEAT_S ?= 30

.DEFAULT_GOAL := help
.PHONY: help setup system-deps demo demo-real test test-fast typecheck check lint format bench server server-postgres postgres-stop worker deploy deploy-script drills clean

help: ## list the targets
	@grep -hE '^[a-z-]+:.*## ' $(MAKEFILE_LIST) | awk -F':.*## ' '{printf "  make %-12s %s\n", $$1, $$2}'

system-deps: ## install the Debian libraries open3d needs (when root), or say which are missing
	@missing=""; for p in $(DEBIAN_PACKAGES); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ]; then echo "installing Debian packages:$$missing"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing >/dev/null; \
	  else echo "ReScene needs the Debian packages:$$missing"; echo "  run: sudo apt-get install$$missing"; exit 1; fi; \
	fi

$(STAMP): pyproject.toml package.json
	@$(MAKE) --no-print-directory system-deps
	@command -v npm >/dev/null || { [ "$$(id -u)" = 0 ] && apt-get install -y -qq npm >/dev/null; } || { echo "ReScene needs npm: sudo apt-get install npm"; exit 1; }
	@test -x $(PY) || python3.11 -m venv $(VENV) || python3 -m venv $(VENV)
	@$(PY) -m pip install -q --upgrade uv
	$(PY) -m uv pip install --python $(PY) -e '.[dev]'
	npm install --no-audit --no-fund --loglevel=error
	$(PY) -m rescene_core.sim.newton_warm
	@touch $(STAMP)

setup: $(STAMP) ## create .venv and install ReScene with its CPU dependencies

demo: $(STAMP) ## synthetic standard capture -> the rescene flow -> where to look
	$(RESCENE) demo --out $(DEMO_DIR) --preset $(PRESET) --seed $(SEED)

REAL_SRC ?= ../shared/data/hololens-000
REAL_DIR ?= $(DEMO_DIR)/real
demo-real: $(STAMP) ## real RGB-D sample -> label-free import (pictures) -> the rescene flow
	$(RESCENE) import rgbd $(REAL_SRC) $(REAL_DIR)/hololens-000.zarr --segment geometric --pictures --overwrite
	PREFECT_SERVER_ANALYTICS_ENABLED=false $(RESCENE) run $(REAL_DIR)/hololens-000.zarr --out $(REAL_DIR)/run
	@echo "pictures: $(REAL_DIR)/hololens-000_contact.png (segments over frames), $(REAL_DIR)/hololens-000_plan.png; run: $(REAL_DIR)/run"

# The suite starts many Python processes (a Prefect server, a worker, flow runs, command lines): they share
# one bytecode cache in the virtual environment instead of each compiling every module it imports.
TEST_BYTECODE := PYTHONDONTWRITEBYTECODE= PYTHONPYCACHEPREFIX=$(abspath $(VENV))/pycache
# Most of the slow tests wait on other processes (a Prefect server, workers, a browser), so two pytest
# processes (pytest-xdist) finish the suite in about two thirds of the time, even on two cores. Each process
# starts its own session Prefect server, so more than a few cost more than they give.
TEST_WORKERS ?= 2
test: $(STAMP) ## run the whole test suite, slow tests included (what CI runs; TEST_WORKERS=2 processes), the 15 slowest listed
	PREFECT_SERVER_ANALYTICS_ENABLED=false $(TEST_BYTECODE) $(PY) -m pytest -n $(TEST_WORKERS) --durations=15

test-fast: $(STAMP) ## the test suite without the slow-marked tests (the edit loop)
	PREFECT_SERVER_ANALYTICS_ENABLED=false $(PY) -m pytest -m "not slow" --durations=10

lint: $(STAMP) ## ruff lint and format check
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .

format: $(STAMP) ## apply ruff formatting and safe fixes
	$(VENV)/bin/ruff check --fix .
	$(VENV)/bin/ruff format .

typecheck: $(STAMP) ## mypy on rescene_core, tasks and flows (settings and files in pyproject.toml [tool.mypy])
	$(PY) -m mypy

check: lint typecheck test ## lint + type check + the whole test suite

bench: $(STAMP) ## run every benchmark suite (SEEDS=0-4) into $(BENCH_DIR)/
	@for s in $$($(RESCENE) bench --list); do $(RESCENE) bench $$s --out $(BENCH_DIR) --seeds $(SEEDS) || exit 1; done

server: $(STAMP) ## start a Prefect server (SQLite; PREFECT_API_DATABASE_CONNECTION_URL for Postgres)
	$(VENV)/bin/prefect server start --host 127.0.0.1

server-postgres: $(STAMP) ## PostgreSQL (Debian's) in PG_DIR on PG_PORT, then a Prefect server on it (several workers)
	$(PY) -m rescene_core.ops.postgres start --dir $(PG_DIR) --port $(PG_PORT)
	PREFECT_API_DATABASE_CONNECTION_URL=$$($(PY) -m rescene_core.ops.postgres url --port $(PG_PORT)) \
	  $(VENV)/bin/prefect server start --host 127.0.0.1

postgres-stop: ## stop the PostgreSQL that make server-postgres started
	$(PY) -m rescene_core.ops.postgres stop --dir $(PG_DIR)

worker: $(STAMP) ## start a process worker on the local pool (its flow runs send heartbeats every HEARTBEAT_S)
	PREFECT_API_URL=$(PREFECT_API_URL) $(VENV)/bin/prefect work-pool create $(POOL) --type process --overwrite >/dev/null
	PREFECT_API_URL=$(PREFECT_API_URL) PREFECT_FLOWS_HEARTBEAT_FREQUENCY=$(HEARTBEAT_S) $(VENV)/bin/prefect worker start --pool $(POOL)

deploy: $(STAMP) ## register the rescene/scene and split deployments with the server (prefect deploy)
	PREFECT_API_URL=$(PREFECT_API_URL) $(VENV)/bin/prefect work-pool create $(POOL) --type process --overwrite >/dev/null
	PREFECT_API_URL=$(PREFECT_API_URL) $(VENV)/bin/prefect --no-prompt deploy --all --prefect-file deployments/prefect.yaml
	PREFECT_API_URL=$(PREFECT_API_URL) $(PY) -c "from deployments.deploy import ensure_crash_detection as e; e(90)"

deploy-script: $(STAMP) ## the same deployments through the Python API (fallback for make deploy)
	PREFECT_API_URL=$(PREFECT_API_URL) $(PY) deployments/deploy.py --prefect-file deployments/prefect.yaml

drills: $(STAMP) ## the fault drills over PostgreSQL and two workers (kill -9, server restart, a split of six; minutes)
	RESCENE_DRILLS=1 PREFECT_SERVER_ANALYTICS_ENABLED=false $(TEST_BYTECODE) $(PY) -m pytest tests/ops -m drill --durations=10

clean: ## remove demo and benchmark outputs (keeps .venv)
	rm -rf $(DEMO_DIR) $(BENCH_DIR) .pytest_cache
