# Every target sets up .venv first (scripts/setup.sh: idempotent, quick when already done).
.PHONY: setup run test bench data generators scrape
BIN := .venv/bin

setup:
	@bash scripts/setup.sh

# the main job: plan a scoop under a 0.4 m/s limit with the shipped models, replay it in simulation
run: setup
	$(BIN)/judgeopt solve --qdot-max 0.4 --plot out/plan.png --out out/plan.csv --overwrite

test: setup
	$(BIN)/python -m pytest -q

bench: setup
	$(BIN)/python benchmarks/bench_rollout.py
	$(BIN)/python benchmarks/bench_planners.py --n 100

# remake the paper's shipped generators, against the judge trained on demonstrations only (about 7 min each
# on one core); the refined judge's generators are fine-tuned from these (docs/remedies.md, docs/planners.md)
generators: setup
	$(BIN)/judgeopt train-generator --problem problems/paper_sim.toml --judge models/judge_default --out models/generator_paper_sim --overwrite
	$(BIN)/judgeopt train-generator --problem problems/paper_sim_slow.toml --judge models/judge_default --out models/generator_paper_sim_slow --overwrite

# remake the shipped datasets (about 18 min on 2 cores; resumable)
data: setup
	$(BIN)/judgeopt collect --out data/train.h5 --seed 0 --per-env 1000 --overwrite
	$(BIN)/judgeopt collect --out data/test.h5 --seed 1 --n 1000 --overwrite
	$(BIN)/judgeopt collect --out data/train_random.h5 --seed 3 --n 15000 --overwrite
	$(BIN)/judgeopt collect --out data/test_seed2.h5 --seed 2 --n 1000 --overwrite
	$(BIN)/judgeopt collect --out data/train_constant.h5 --seed 4 --n 15000 --set commands.constant_force_share=0.4 --overwrite

# the second task end to end (docs/tasks.md): demonstrations (about 12 min on 2 cores; resumable),
# its judge, a generator per limit set, and both planners evaluated in simulation on 100 environments
scrape: setup
	$(BIN)/judgeopt collect --task scrape --out data/scrape/train.h5 --seed 0 --n 10000 --overwrite
	$(BIN)/judgeopt collect --task scrape --out data/scrape/test.h5 --seed 1 --n 1000 --overwrite
	$(BIN)/judgeopt collect --task scrape --out data/scrape/test_seed2.h5 --seed 2 --n 1000 --overwrite
	$(BIN)/judgeopt train-judge --train data/scrape/train.h5 --test data/scrape/test.h5 --out models/scrape/judge --overwrite
	$(BIN)/judgeopt train-generator --problem problems/scrape.toml --out models/scrape/generator --overwrite
	$(BIN)/judgeopt train-generator --problem problems/scrape_slow.toml --out models/scrape/generator_slow --overwrite
	$(BIN)/judgeopt evaluate planners --problem problems/scrape.toml --n 100 --out docs/results/scrape
	$(BIN)/judgeopt evaluate planners --problem problems/scrape_slow.toml --n 100 --out docs/results/scrape_slow
