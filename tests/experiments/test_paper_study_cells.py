"""The study file: the paper's study on the -v1 envs."""


def test_the_study_is_the_papers_protocol_on_the_v1_envs():
    """The shipped study's cells: the paper's four algorithms on a -v1 id, episodes to the step
    limit, the paper's budget but for DDPG's stated smaller one."""
    from drake_tooluse.experiments.paper_study_cells import load_cells
    from drake_tooluse.learning.config import load_hyperparams

    cells, episodes, seed = load_cells()
    assert episodes == 100 and seed == 1000
    assert list(cells)[:2] == ["v1_ppo", "v1_ppo_paper_action"]
    assert {c["algo"] for c in cells.values()} == {"ppo", "trpo", "a2c", "ddpg"}
    for cell in cells.values():
        assert cell["env"].endswith("-v1") and cell["protocol"] == "to-limit"
        assert cell["timesteps"] == (300_000 if cell["algo"] == "ddpg" else 1_250_000)
    assert len(cells["v1_ppo"]["seeds"]) == 5
    assert cells["v1_ddpg"]["seeds"] == [0, 1, 2]
    # As its comment says: the replay buffer keeps every transition of a DDPG run.
    ddpg = cells["v1_ddpg"]
    assert ddpg["timesteps"] <= load_hyperparams("ddpg", ddpg["env"])["buffer_size"]
