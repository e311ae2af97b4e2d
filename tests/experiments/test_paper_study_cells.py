"""The study files: the -v1 study's cells."""


def test_the_v1_study_is_the_papers_protocol_on_the_v1_envs():
    """The -v1 study's cells: PPO, TRPO and A2C of the paper's algorithms (DDPG apart) on a -v1
    id, episodes to the step limit, the paper's budget."""
    from drake_tooluse.experiments.paper_study_cells import PAPER_STUDY_CELLS, load_cells

    cells, episodes, _ = load_cells(PAPER_STUDY_CELLS.parent / "paper_study_v1.yaml")
    assert episodes == 100
    assert {c["algo"] for c in cells.values()} == {"ppo", "trpo", "a2c"}
    for cell in cells.values():
        assert cell["env"].endswith("-v1") and cell["protocol"] == "to-limit"
        assert cell["timesteps"] == 1_250_000
    assert len(cells["v1_ppo"]["seeds"]) == 5
