"""$JUDGEOPT_MODELS: a folder of your own models looked up before the shipped ones (files.resolve):
the same name there wins, a name only there is found, a name only shipped still is, and without
the variable the shipped models answer. Run from another folder, where the checkout's models/
link is not in reach."""

from __future__ import annotations

import json
import shutil

import pytest

from judgeopt.cli import main
from judgeopt.files import MODELS_ENV, resolve, shipped_models


@pytest.fixture
def mine(tmp_path, monkeypatch):
    own = tmp_path / "my_models"
    own.mkdir()
    for suffix in (".json", ".pt"):
        shutil.copy(shipped_models() / f"judge_demos_tcn{suffix}", own / f"judge_demos_tcn{suffix}")
        shutil.copy(shipped_models() / f"judge_demos_tcn{suffix}", own / f"only_mine{suffix}")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    return own


def test_own_models_come_before_the_shipped_ones(mine, monkeypatch):
    monkeypatch.setenv(MODELS_ENV, str(mine))
    assert resolve("models/judge_demos_tcn", (".json",)) == mine / "judge_demos_tcn"
    assert resolve("models/only_mine", (".json",)) == mine / "only_mine"
    assert resolve("models/judge_refined", (".json",)) == shipped_models() / "judge_refined"


def test_without_the_variable_the_shipped_models_answer(mine, monkeypatch):
    monkeypatch.delenv(MODELS_ENV, raising=False)
    assert resolve("models/judge_demos_tcn", (".json",)) == shipped_models() / "judge_demos_tcn"
    assert resolve("models/only_mine", (".json",)) != mine / "only_mine"


def test_solve_plans_with_a_judge_found_there(mine, monkeypatch, capsys):
    monkeypatch.setenv(MODELS_ENV, str(mine))
    assert main(["solve", "--judge", "models/only_mine", "--method", "direct", "--no-simulate", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["judge"] == str(mine / "only_mine")


# -- the index of the shipped models (docs/models.md, `judgeopt models`) ------------------------------
SHIPPED = shipped_models()
PROBLEMS = sorted((SHIPPED.parent / "tasks").glob("*/problems/*.toml"))


def _index() -> dict[str, list[dict]]:
    from judgeopt.model_index import index
    from judgeopt.tasks import task_names

    return {t: [e.to_dict() for e in index(t)] for t in task_names()}


def _judge_sha(problem) -> str:
    from judgeopt.judge.store import load_meta

    return load_meta(resolve(problem.judge, (".json",)))["weights_sha256"]


def test_every_model_file_is_in_the_index_once(monkeypatch):
    monkeypatch.delenv(MODELS_ENV, raising=False)
    names = [e["name"] for entries in _index().values() for e in entries]
    files = {f"models/{p.relative_to(SHIPPED).with_suffix('').as_posix()}" for p in SHIPPED.rglob("*.pt")
             if not (p.parent / "ensemble.json").exists()}
    files |= {f"models/{p.parent.relative_to(SHIPPED).as_posix()}" for p in SHIPPED.rglob("ensemble.json")}
    files |= {f"models/{p.stem}" for p in SHIPPED.glob("*.json")
              if p.stem.startswith(("calibration_", "trust_region_"))}
    assert sorted(names) == sorted(set(names)) and set(names) == files


def test_the_weights_are_those_their_metadata_records():
    """Renamed and moved models keep their weights byte for byte (the load check says the same)."""
    from judgeopt.files import sha256_file

    for pt in SHIPPED.rglob("*.pt"):
        meta = json.loads(pt.with_suffix(".json").read_text())
        assert sha256_file(pt) == meta["weights_sha256"], pt
        assert meta["weights_file"] == pt.name, pt


def test_every_generator_names_a_shipped_judge_or_says_what_it_was(monkeypatch):
    monkeypatch.delenv(MODELS_ENV, raising=False)
    for entries in _index().values():
        judges = {e["name"] for e in entries if e["kind"] == "judge"}
        for e in (e for e in entries if e["kind"] == "generator"):
            assert e["trained_against"] in judges or ("not shipped" in e["trained_against"] and e["note"]), e
            if e["trained_against"] in judges:
                assert e["name"] in next(j for j in entries if j["name"] == e["trained_against"])["generators"]


def test_the_experiments_are_marked_and_say_what_they_are_kept_for(monkeypatch):
    monkeypatch.delenv(MODELS_ENV, raising=False)
    entries = [e for es in _index().values() for e in es]
    kept = [e for e in entries if e["experiment"]]
    assert kept and all(e["name"].startswith("models/experiments/") and e["note"] and not e["defaults"] for e in kept)
    assert not [e for e in entries if "default" in e["name"].rsplit("/", 1)[-1] and e["kind"] in ("judge", "generator")]


@pytest.mark.parametrize("path", PROBLEMS, ids=lambda p: p.stem)
def test_a_problem_file_plans_with_the_generator_it_names(path, monkeypatch):
    """The named generator exists, fits the file's limits and was trained against its judge, and
    `solve` chooses it; a file that names none has none that fits (the search finds none either)."""
    from judgeopt.planners.loaded import choose_models
    from judgeopt.planners.problem import load_problem
    from judgeopt.planners.store import load_generator_meta, misfit

    monkeypatch.delenv(MODELS_ENV, raising=False)
    problem = load_problem(path)
    chosen = choose_models(problem, ("amortized", "direct"))
    if problem.generator_model:
        named = resolve(problem.generator_model, (".json",))
        assert misfit(load_generator_meta(named), problem, _judge_sha(problem)) is None
        assert chosen.generator.resolve() == named.resolve()
    else:
        assert chosen.generator is None


def test_the_named_generator_comes_first_and_the_search_is_the_fallback(monkeypatch):
    from judgeopt.planners.problem import load_problem
    from judgeopt.planners.store import GeneratorFileError, find_generator

    monkeypatch.delenv(MODELS_ENV, raising=False)
    demos = load_problem("paper_sim_ensemble")  # the demonstrations-only judge at q̇_max = 1.0
    sha = _judge_sha(demos)
    # the search prefers the per-limit generator; a file that names the conditioned one gets it
    assert find_generator(SHIPPED, demos.with_overrides(generator_model=""), sha).name == "generator_paper_sim"
    conditioned = demos.with_overrides(generator_model="models/generator_conditioned")
    assert find_generator(SHIPPED, conditioned, sha).name == "generator_conditioned"
    # limits it was not trained for: the search finds one that fits
    assert find_generator(SHIPPED, demos.with_overrides(qdot_max=0.4), sha).name == "generator_paper_sim_slow"
    # another judge: the named one does not fit it, the search finds that judge's
    refined = load_problem("paper_sim")
    assert find_generator(SHIPPED, demos.with_overrides(judge=refined.judge), _judge_sha(refined)).name == \
        "generator_conditioned_refined"
    with pytest.raises(GeneratorFileError, match=r"generator_model = 'models/nowhere'.*set it to \"\""):
        find_generator(SHIPPED, demos.with_overrides(generator_model="models/nowhere"), sha)


def test_models_marks_the_default_that_solve_and_load_judge_use(monkeypatch, capsys):
    """By the weights, not by name: the judge `judgeopt models` marks for solve's default problem,
    the one `solve` chooses, and the one `judgeopt.load_judge()` loads are the same network."""
    import judgeopt
    from judgeopt.cli.planners import DEFAULT_PROBLEM
    from judgeopt.judge.casadi_fn import model_hash
    from judgeopt.judge.store import load_meta
    from judgeopt.planners.loaded import choose_models
    from judgeopt.planners.problem import load_problem

    monkeypatch.delenv(MODELS_ENV, raising=False)
    assert main(["models", "--json"]) == 0
    label = f"judge of {DEFAULT_PROBLEM}"
    marked = [e["name"] for es in json.loads(capsys.readouterr().out).values() for e in es if label in e["defaults"]]
    assert len(marked) == 1
    chosen = choose_models(load_problem(resolve(DEFAULT_PROBLEM)), ("amortized", "direct"))
    assert load_meta(resolve(marked[0], (".json",)))["weights_sha256"] == chosen.shas["judge"]
    assert model_hash(judgeopt.load_judge()) == model_hash(judgeopt.load_judge(marked[0]))


def test_models_prints_what_a_user_needs_not_the_history(monkeypatch, capsys):
    """Each shipped model with what it is, what it is for and its key figure; no issue numbers or
    working folders (out/...): that history is in docs/models.md. The default judge's figure is its
    metadata's test accuracy, read here from its JSON."""
    monkeypatch.delenv(MODELS_ENV, raising=False)
    assert main(["models"]) == 0
    out = capsys.readouterr().out
    assert "issue " not in out.lower() and "out/" not in out
    shipped = [e for es in _index().values() for e in es if not e["experiment"]]
    blocks = {b.split(" (", 1)[0].strip(): b for b in out.split("\n  models/")[1:]}
    assert {f"models/{n}" for n in blocks} == {e["name"] for e in shipped}  # every shipped one, no experiment
    for name, block in blocks.items():
        assert "what: " in block and "for: " in block, name
    accuracy = json.loads((SHIPPED / "judge_refined.json").read_text())["metrics"]["test_accuracy"]
    assert f"figure: test accuracy {accuracy:.3f}" in blocks["judge_refined"]
    assert "problems/paper_sim.toml" in blocks["judge_refined"].split("for: ", 1)[1]
    assert "docs/models.md" in out


def test_docs_models_md_is_what_the_index_prints_now(monkeypatch):
    from judgeopt.cli.models import markdown

    monkeypatch.delenv(MODELS_ENV, raising=False)
    text = (SHIPPED.parent.parent / "docs" / "models.md").read_text()
    begin, end = "<!-- judgeopt models --markdown: begin -->\n", "<!-- judgeopt models --markdown: end -->"
    assert text.split(begin, 1)[1].split(end, 1)[0] == markdown(_index()), \
        "docs/models.md is out of date: put `judgeopt models --markdown` between its markers"


def test_no_code_names_a_model_that_is_not_there():
    """After a rename, every `models/NAME` the code, tests, scripts, notebooks and problem files name
    exists (names a command writes, and placeholders, aside)."""
    import re

    repo = SHIPPED.parent.parent
    written = {"models/mine", "models/only_mine", "models/scrape/generator_conditioned"}  # by a command
    written |= {"models/x", "models/nowhere", "models/elsewhere"}  # placeholders, and the missing file a test names on purpose
    files = [p for d in ("judgeopt", "tests", "scripts", "benchmarks", "notebooks") for p in (repo / d).rglob("*")
             if p.suffix in (".py", ".ipynb", ".toml") and "models" not in p.relative_to(repo).parts[1:2]]
    missing = set()
    for f in [*files, repo / "Makefile", repo / "README.md"]:
        for name in re.findall(r"(?<![\w./])models/[\w/]*\w", f.read_text()):
            if name not in written and "NAME" not in name and not any(
                    (SHIPPED.parent / (name + s)).exists() for s in ("", ".json", ".pt")):
                missing.add(f"{f.relative_to(repo)}: {name}")
    assert not missing, sorted(missing)


def test_inspect_says_what_a_generator_is_in_readable_lines(capsys, monkeypatch):
    """The task (also for files from before generators recorded it), the judge by name, and the
    model it continued only where that is another one; no raw dicts, no None."""
    monkeypatch.delenv(MODELS_ENV, raising=False)
    assert main(["inspect", "models/generator_conditioned_refined"]) == 0
    text = capsys.readouterr().out
    assert "task           : scoop" in text and "against        : models/judge_refined" in text
    assert "None" not in text and "{" not in text and "continued from" not in text  # fine-tuned from itself
    assert main(["inspect", "models/scrape/generator_refined"]) == 0
    text = capsys.readouterr().out
    assert "task           : scrape" in text and "continued from : round 5 of the refinement" in text
    assert main(["inspect", "models/experiments/generator_paper_sim_slow_pessimistic"]) == 0
    text = capsys.readouterr().out
    assert "the pessimistic score of models/judge_ensemble" in text and "a judge not shipped" in text
