# Every target sets up .venv first (scripts/setup.sh: idempotent, quick when already done).
.PHONY: setup run test docs mutation bench data generators scrape scrape-trust lab-recordings section5
BIN := .venv/bin

setup:
	@bash scripts/setup.sh

# the main job: plan a scoop under a 0.4 m/s limit with the shipped models, replay it in simulation
run: setup
	$(BIN)/judgeopt solve --qdot-max 0.4 --plot out/plan.png --out out/plan.csv --overwrite

test: setup
	$(BIN)/python -m pytest -q

# the docs site (mkdocs.yml: docs/, the API reference from the docstrings, the notebooks as committed) into site/
docs: setup
	$(BIN)/mkdocs build --strict --site-dir site

# mutation testing of the code that prints a probability and its verdict ([tool.mutmut] in pyproject.toml;
# not in CI: about half an hour on 2 cores). Survivors: .venv/bin/mutmut results
mutation: setup
	$(BIN)/python -m pip install -q mutmut==3.8.1
	rm -rf mutants && $(BIN)/mutmut run --max-children 2; $(BIN)/mutmut results

bench: setup
	$(BIN)/python benchmarks/bench_rollout.py
	$(BIN)/python benchmarks/bench_planners.py --n 100

# remake the paper's shipped generators, against the judge trained on demonstrations only (about 7 min each
# on one core); the refined judge's generators are fine-tuned from these (docs/remedies.md, docs/planners.md)
generators: setup
	$(BIN)/judgeopt train-generator --problem problems/paper_sim.toml --judge models/judge_demos_tcn --out models/generator_paper_sim --overwrite
	$(BIN)/judgeopt train-generator --problem problems/paper_sim_slow.toml --judge models/judge_demos_tcn --out models/generator_paper_sim_slow --overwrite

# remake the shipped datasets (about 18 min on 2 cores; resumable)
data: setup
	$(BIN)/judgeopt collect --out data/train.h5 --seed 0 --per-env 1000 --overwrite
	$(BIN)/judgeopt collect --out data/test.h5 --seed 1 --n 1000 --overwrite
	$(BIN)/judgeopt collect --out data/train_random.h5 --seed 3 --n 15000 --overwrite
	$(BIN)/judgeopt collect --out data/test_seed2.h5 --seed 2 --n 1000 --overwrite
	$(BIN)/judgeopt collect --out data/train_constant.h5 --seed 4 --n 15000 --set commands.constant_force_share=0.4 --overwrite

# human-style scoops recorded in the simulated lab (y_obj = 0.246 m, mu = 0.5), written as a lab writes them: one
# CSV per recording (120 Hz motion capture and 1 kHz force on their own rows), labels.csv with 3 % of labels wrong
# (judgeopt/tasks/scoop/lab_recordings.py; about a minute on 2 cores)
lab-recordings: setup
	$(BIN)/python -m judgeopt.tasks.scoop.lab_recordings --out out/lab --n 400 --seed 0 --overwrite

# the paper's Section V in simulation (docs/results/section5.md; about 15 min on 2 cores). A lab's recordings made in the
# scene and written as its raw files (UNIX time, 120 Hz motion capture and 1 kHz force on separate rows, force negative
# with a 0.3 N bias, no velocity, rests, 3 % of labels wrong), imported with one command each, a judge on y_obj alone,
# a generator per Table 8 velocity limit, both planners' plans tried 10 times; then a lab no file here describes
# (250 Hz, millimetres, force positive, 0.5 N bias, 5 % wrong labels) scored by the same judge
LAB := out/section5
LAB_IMPORT := --columns t=time,y=tool_y_m,f=fz_N --scale f=-1 --tare --env-names y_obj --env y_obj=0.246 --align onset --fit resample --overwrite
section5: setup
	$(BIN)/python -m judgeopt.tasks.scoop.lab_recordings --out $(LAB)/train --n 1000 --seed 0 --overwrite
	$(BIN)/python -m judgeopt.tasks.scoop.lab_recordings --out $(LAB)/test --n 115 --seed 1 --overwrite
	$(BIN)/judgeopt import-demos $(LAB)/train/recordings --labels $(LAB)/train/labels.csv $(LAB_IMPORT) --out $(LAB)/train.h5
	$(BIN)/judgeopt import-demos $(LAB)/test/recordings --labels $(LAB)/test/labels.csv $(LAB_IMPORT) --out $(LAB)/test.h5
	$(BIN)/judgeopt import-demos $(LAB)/test/recordings --labels $(LAB)/test/labels_true.csv $(LAB_IMPORT) --out $(LAB)/test_true.h5
	$(BIN)/judgeopt train-judge --train $(LAB)/train.h5 --test $(LAB)/test.h5 --env-names y_obj --seed 0 --out models/judge_lab --overwrite
	$(BIN)/judgeopt test-judge --judge models/judge_lab --data $(LAB)/test.h5
	$(BIN)/judgeopt test-judge --judge models/judge_lab --data $(LAB)/test_true.h5
	$(BIN)/judgeopt train-generator --problem problems/paper_real.toml --epochs 3000 --out models/generator_lab --overwrite
	$(BIN)/judgeopt train-generator --problem problems/paper_real.toml --qdot-max 0.4 --epochs 3000 --out models/generator_lab_slow --overwrite
	$(BIN)/judgeopt evaluate trials --problem problems/paper_real.toml --qdot-max 1.0,0.4 --n 1 --trials 10 --out docs/results/section5
	$(BIN)/python -m judgeopt.tasks.scoop.lab_recordings --out $(LAB)/other --n 200 --seed 2 --overwrite --set mocap_rate=250 --set position_unit=mm --set force_sign=1 --set force_bias=0.5 --set label_noise=0.05 --set columns=stamp,tool_y_mm,force_N
	$(BIN)/judgeopt import-demos $(LAB)/other/recordings --labels $(LAB)/other/labels_true.csv --columns t=stamp,y=tool_y_mm,f=force_N --scale y=mm --tare --env-names y_obj --env y_obj=0.246 --align onset --fit resample --overwrite --out $(LAB)/other_true.h5
	$(BIN)/judgeopt test-judge --judge models/judge_lab --data $(LAB)/other_true.h5

# the second task end to end (docs/tasks.md): demonstrations (about 12 min on 2 cores; resumable),
# its judge, a generator per limit set, and both planners evaluated in simulation on 100 environments
scrape: setup
	$(BIN)/judgeopt collect --task scrape --out data/scrape/train.h5 --seed 0 --n 10000 --overwrite
	$(BIN)/judgeopt collect --task scrape --out data/scrape/test.h5 --seed 1 --n 1000 --overwrite
	$(BIN)/judgeopt collect --task scrape --out data/scrape/test_seed2.h5 --seed 2 --n 1000 --overwrite
	$(BIN)/judgeopt train-judge --train data/scrape/train.h5 --test data/scrape/test.h5 --out models/scrape/judge_demos --overwrite
	$(BIN)/judgeopt train-generator --problem problems/scrape.toml --judge models/scrape/judge_demos --out models/scrape/generator --overwrite
	$(BIN)/judgeopt train-generator --problem problems/scrape_slow.toml --judge models/scrape/judge_demos --out models/scrape/generator_slow --overwrite
	$(BIN)/judgeopt evaluate planners --problem problems/scrape.toml --n 100 --out docs/results/scrape
	$(BIN)/judgeopt evaluate planners --problem problems/scrape_slow.toml --n 100 --out docs/results/scrape_slow
	$(MAKE) scrape-trust

# the scrape's judge refined over its limit space (4 rounds of the direct solve, then 2 with the generator conditioned
# on the limits as well); a calibration over limits fitted for comparison (not shipped); held-out limits and
# environments (docs/remedies.md; about 50 min on 2 cores, every step resumable)
SCRAPE_REFINE := --problem problems/scrape.toml --judge models/scrape/judge_demos --sample-limits --n 200 --weight 8 --judge-epochs 3 --seed 1 --train data/scrape/train.h5 --test data/scrape/test.h5 --out out/refine_scrape
scrape-trust: setup
	$(BIN)/judgeopt refine $(SCRAPE_REFINE) --rounds 4 --install scrape/refined --overwrite
	$(BIN)/judgeopt train-generator --problem problems/scrape.toml --judge models/scrape/judge_refined --conditioned --epochs 3000 --threads 2 --out models/scrape/generator_conditioned --overwrite
	$(BIN)/judgeopt refine $(SCRAPE_REFINE) --rounds 6 --methods direct amortized --generator models/scrape/generator_conditioned --generator-epochs 1000 --install scrape/refined --overwrite
	rm -f models/scrape/generator_conditioned.*
	$(BIN)/judgeopt evaluate sweep --problem problems/scrape.toml --random-limits 24 --n 25 --seed 5 --no-baselines --out out/sweep_scrape_fit
	$(BIN)/judgeopt evaluate planners --problem problems/scrape.toml --n 50 --seed 5 --out out/planners_scrape_fit
	$(BIN)/judgeopt calibrate out/sweep_scrape_fit out/planners_scrape_fit --over-limits --replace --out out/scrape_calibration.json
	$(BIN)/judgeopt evaluate sweep --problem problems/scrape.toml --random-limits 12 --n 25 --seed 6 --no-baselines --out docs/results/sweep_scrape
	$(BIN)/judgeopt evaluate sweep --problem problems/scrape.toml --random-limits 12 --n 25 --seed 6 --no-baselines --calibration out/scrape_calibration.json --out docs/results/sweep_scrape_calibrated
	$(BIN)/judgeopt evaluate planners --problem problems/scrape.toml --n 100 --seed 0 --out docs/results/scrape_refined
	$(BIN)/judgeopt evaluate sweep --problem problems/scrape.toml --judge models/scrape/judge_demos --random-limits 12 --n 25 --seed 6 --no-baselines --methods direct cem --out docs/results/sweep_scrape_demojudge