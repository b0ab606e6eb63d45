"""The example nodes and their launch file (config/launch/example.yaml)."""

from __future__ import annotations

from quadmission.examples import Listener, Talker, TalkerParams
from runtime import DeterministicExecutor, LaunchDescription, launch
from runtime.parameters import config_path, load_parameters

EXAMPLE_LAUNCH = config_path("launch/example.yaml")


def test_the_talker_publishes_at_its_configured_rate() -> None:
    rate_hz = load_parameters(TalkerParams, "talker").rate_hz  # config/talker.yaml
    ex = DeterministicExecutor()
    listener = Listener(context=ex.context)
    ex.add_node(Talker(context=ex.context))
    ex.add_node(listener)
    ex.spin_for(1.0)
    assert listener.heard == [f"hello {n}" for n in range(1, round(rate_hz) + 1)]


def test_the_example_launch_file_runs_the_talker_and_the_listener() -> None:
    description = LaunchDescription.from_yaml(EXAMPLE_LAUNCH)
    rate_hz = description.nodes[0].parameters["rate_hz"]
    ex = DeterministicExecutor()
    talker, listener = launch(description, ex)
    ex.spin_for(2.0)
    assert talker.params.rate_hz == rate_hz  # the launch file's override won
    assert listener.heard == [f"hello {n}" for n in range(1, round(2.0 * rate_hz) + 1)]
