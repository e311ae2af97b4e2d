import pytest
import torch


@pytest.fixture(autouse=True)
def _single_thread():
    """As the train command runs: one torch thread (the env is the work)."""
    torch.set_num_threads(1)
