"""benchmarks/across_builds.py: the comparison that measured the shipped tests' tolerances."""

import json

from tests.benchmark_scripts import benchmark_script

across = benchmark_script("across_builds")


def _episode(seed, distance, success):
    return {"seed": seed, "final_object_to_goal_m": distance, "success": success}


def test_it_counts_what_differs_what_branched_and_what_flipped(tmp_path, capsys):
    shipped = [_episode(1, 0.010, True), _episode(2, 0.020, True), _episode(3, 0.030, True)]
    other = [_episode(1, 0.010, True), _episode(2, 0.022, True), _episode(3, 0.090, False)]
    first, second = tmp_path / "metrics.json", tmp_path / "other.json"
    first.write_text(json.dumps({"evaluation": {"per_episode": shipped}}))
    second.write_text(json.dumps({"per_episode": other}))
    result = across.compare(
        across.load_evaluation(first), across.load_evaluation(second), "final_object_to_goal_m"
    )
    assert result["differ"] == 2 and result["beyond_tolerance"] == 1 and result["flipped"] == [3]
    assert abs(result["max_m"] - 0.06) < 1e-12
    assert abs(result["mean_shift_m"] + 0.062 / 3) < 1e-12
    assert across.main([str(first), str(second)]) == 0
    assert "2 of 3 episodes differ" in capsys.readouterr().out


def test_other_seeds_or_no_episodes_are_one_line(tmp_path, capsys):
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.write_text(json.dumps({"per_episode": [_episode(1, 0.0, True)]}))
    b.write_text(json.dumps({"per_episode": [_episode(2, 0.0, True)]}))
    assert across.main([str(a), str(b)]) == 2
    assert (
        capsys.readouterr().err.strip() == "across_builds: the two evaluations ran different seeds"
    )
    b.write_text("{}")
    assert across.main([str(a), str(b)]) == 2
    assert "no per-episode evaluation" in capsys.readouterr().err
