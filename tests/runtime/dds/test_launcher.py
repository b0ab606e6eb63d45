"""A DDS launch ends when a process dies, says which one, and stops the others."""

from __future__ import annotations

import io

from runtime.dds.config import DdsConfig
from runtime.dds.launcher import process_specs, run_launch
from runtime.launch import LaunchDescription, NodeSpec


def test_a_dead_child_ends_the_launch_naming_it(dds_config: DdsConfig) -> None:
    description = LaunchDescription((
        NodeSpec("quadmission.examples:Listener", process="waiting"),  # waits for /clock
        NodeSpec("runtime.no_such_module:Node", process="broken"),
    ))
    specs = process_specs(description, domain_id=dds_config.domain_id, config_dir=None,
                          startup_timeout_s=60.0)
    assert [s.name for s in specs] == ["waiting", "broken"]
    log = io.StringIO()
    result = run_launch(specs, log=log)
    assert result.exit_code == 1
    assert "process 'broken'" in result.reason and "died" in result.reason
    assert "started waiting" in log.getvalue()  # and it was stopped: run_launch returned
