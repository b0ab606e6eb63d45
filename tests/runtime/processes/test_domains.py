"""Every process test is on a ROS 2 domain no other test process holds.

Two pytest-xdist workers of one run, or of two runs at once (a developer's and CI's), each
claim their domains by an exclusive lock on a file per domain (``DomainClaims``), so no two
live test processes share one, whatever their run ids and worker numbers; the lock dies
with its process. And no test names a domain of its own: a launch over ``ros2`` gets
``--domain-id`` from the fixture, never a number written in the test.
"""

from __future__ import annotations

import ast
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from tests.runtime.processes.conftest import (
    _DOMAIN_USERS,
    TEST_DOMAINS,
    DomainClaims,
    ros_domain,
)

ROOT = Path(__file__).resolve().parents[3]
TESTS = ROOT / "tests"

#: a process claiming every user's domain from ``lock_dir``, printing them, holding them
#: until its stdin closes (a worker of a test run, as far as the domains go)
_WORKER = textwrap.dedent("""
    import sys
    from pathlib import Path
    from tests.runtime.processes.conftest import DomainClaims, _DOMAIN_USERS
    claims = DomainClaims(Path(sys.argv[1]), range(int(sys.argv[2]), int(sys.argv[3])))
    print(*(claims.domain(user) for user in _DOMAIN_USERS), flush=True)
    sys.stdin.read()
""")


def _workers(lock_dir: Path, domains: range, count: int) -> list[subprocess.Popen[str]]:
    return [subprocess.Popen([sys.executable, "-c", _WORKER, str(lock_dir), str(domains.start),
                              str(domains.stop)], cwd=ROOT, stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, text=True) for _ in range(count)]


def _stop(workers: list[subprocess.Popen[str]]) -> None:
    for worker in workers:
        worker.communicate(timeout=60)


def test_live_test_processes_never_share_a_domain(tmp_path: Path) -> None:
    # Three workers at once on a range with room for exactly them: each must get its own
    # domains, whatever their pids make them try first.
    domains = range(100, 100 + 3 * len(_DOMAIN_USERS))
    workers = _workers(tmp_path, domains, 3)
    try:
        claimed = [[int(d) for d in w.stdout.readline().split()] for w in workers]  # type: ignore[union-attr]
    finally:
        _stop(workers)
    every = [d for mine in claimed for d in mine]
    assert all(len(mine) == len(_DOMAIN_USERS) for mine in claimed), claimed
    assert len(set(every)) == len(every), f"two test processes share a domain: {claimed}"
    assert set(every) <= set(domains)


def test_a_domain_is_free_again_when_its_process_ends(tmp_path: Path) -> None:
    domains = range(100, 100 + len(_DOMAIN_USERS))
    first = _workers(tmp_path, domains, 1)
    held = [int(d) for d in first[0].stdout.readline().split()]  # type: ignore[union-attr]
    _stop(first)
    second = _workers(tmp_path, domains, 1)
    try:
        again = [int(d) for d in second[0].stdout.readline().split()]  # type: ignore[union-attr]
    finally:
        _stop(second)
    assert sorted(again) == sorted(held) == list(domains)


def test_a_full_range_is_refused_naming_the_locks(tmp_path: Path) -> None:
    holder, late = DomainClaims(tmp_path, range(150, 152)), DomainClaims(tmp_path, range(150, 152))
    try:
        assert {holder.domain("runtime"), holder.domain("square")} == {150, 151}
        assert holder.domain("runtime") == holder.domain("runtime")  # claimed once
        with pytest.raises(RuntimeError, match=r"150\.\.151 is held .*" + str(tmp_path)):
            late.domain("runtime")
    finally:
        holder.release()
        late.release()


def test_this_process_domains_are_test_domains_and_distinct() -> None:
    mine = [ros_domain(user) for user in _DOMAIN_USERS]
    assert len(set(mine)) == len(mine) and set(mine) <= set(TEST_DOMAINS)
    assert 0 not in TEST_DOMAINS and TEST_DOMAINS.stop - 1 <= 232
    with pytest.raises(ValueError, match="not one of the domain users"):
        ros_domain("nobody")


def _hard_coded_domains(source: str, name: str) -> list[str]:
    """Calls in ``source`` (the file ``name``) that would put a process on a domain written
    in the test: a ``--domain-id`` followed by a number, a ``domain_id=`` number, or a
    subprocess started with ``ros2`` in its argument list and no ``--domain-id``."""
    found = []
    for call in (n for n in ast.walk(ast.parse(source)) if isinstance(n, ast.Call)):
        where = f"{name}:{call.lineno}"
        for keyword in call.keywords:
            if keyword.arg == "domain_id" and isinstance(keyword.value, ast.Constant):
                found.append(f"{where}: domain_id={keyword.value.value!r}")
        for args in (a for a in call.args if isinstance(a, ast.List)):
            values = [str(e.value) if isinstance(e, ast.Constant) else None for e in args.elts]
            for k, value in enumerate(values[:-1]):
                following = values[k + 1]
                # outside 0..232 is a refusal being tested: it never reaches a graph
                if value == "--domain-id" and following is not None \
                        and 0 <= int(following) <= 232:
                    found.append(f"{where}: --domain-id {following}")
            starts = isinstance(call.func, ast.Attribute) and call.func.attr in (
                "Popen", "run", "check_output", "check_call", "call")
            if starts and "ros2" in values and "--domain-id" not in values:
                found.append(f"{where}: a ros2 process without --domain-id (domain 0)")
    return found


def test_the_hard_coded_domain_check_catches_each_way() -> None:
    found = _hard_coded_domains(textwrap.dedent("""
        subprocess.run(["launch", "x.yaml", "--transport", "ros2", "--domain-id", "7"])
        subprocess.Popen(["launch", "x.yaml", "--transport", "ros2"])
        ProcessSpec("a", domain_id=3)
        main(["launch", "--transport", "ros2", "--domain-id", "300"])
        subprocess.run(["launch", "--transport", "ros2", "--domain-id", str(ros_domain("x"))])
    """), "sample.py")
    assert [f.split(": ", 1)[1] for f in found] == [
        "--domain-id 7", "a ros2 process without --domain-id (domain 0)", "domain_id=3"], found


def test_no_test_puts_a_process_on_a_domain_of_its_own_choosing() -> None:
    found = [f for path in sorted(TESTS.rglob("*.py")) for f in _hard_coded_domains(
        path.read_text(encoding="utf-8"), str(path.relative_to(ROOT)))]
    assert not found, ("tests that choose a ROS 2 domain instead of the fixture's "
                       "(ros_domain / domain_id):\n" + "\n".join(found))
