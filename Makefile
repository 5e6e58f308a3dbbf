# Every target sets up .venv first (scripts/setup.sh: idempotent, quick when already done).
.PHONY: setup run test bench data
BIN := .venv/bin

setup:
	@bash scripts/setup.sh

# the main job (until the planners land): summarise the shipped data, replay and render two scoops
run: setup
	$(BIN)/judgeopt inspect data/train.h5
	$(BIN)/judgeopt plot-data --data data/train.h5 --out out/velocity_force.png
	$(BIN)/judgeopt render --data data/test.h5 --successes 1 --failures 1 --out out/renders

test: setup
	$(BIN)/python -m pytest -q

bench: setup
	$(BIN)/python benchmarks/bench_rollout.py

# remake the shipped datasets (about 30 min on 2 cores; resumable)
data: setup
	$(BIN)/judgeopt collect --out data/train.h5 --seed 0 --per-env 1000
	$(BIN)/judgeopt collect --out data/test.h5 --seed 1 --n 1000
