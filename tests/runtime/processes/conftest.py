"""The process transport (``ros2``: rclpy on Fast DDS) on a loopback-only domain of this test
session's own; its tests skip, naming the command, where the ROS 2 build is missing (never
under ``make test``, which builds it: tests/conftest.py).
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import tempfile
from pathlib import Path

import pytest

from runtime.processes.child import ProcessSpec
from runtime.processes.executor import ProcessTransport
from runtime.ros2.config import SETUP_HINT, missing_modules

needs_ros2 = pytest.mark.skipif(
    bool(missing_modules()), reason=f"the ROS 2 wheels or interface packages are missing: "
                                    f"{SETUP_HINT}")
TRANSPORT_KINDS = [pytest.param("ros2", marks=needs_ros2)]


#: the tests that start ROS 2 processes, each on a domain of its own (ros_domain)
_DOMAIN_USERS = ("runtime", "square", "ground_station", "user_node", "vehicle")
#: the domains tests claim: 100..229 (ROS 2 domain ids end at 232)
TEST_DOMAINS = range(100, 230)
#: one lock file per domain, machine-wide: every checkout's test runs (a developer's and
#: CI's, every xdist worker) claim their domains here
DOMAIN_LOCKS = Path(tempfile.gettempdir()) / "quadmission-ros2-domains"


class DomainClaims:
    """Domains this process holds, one per user, each by an exclusive ``flock`` on its
    file under ``lock_dir`` for as long as the process lives (the kernel drops the lock
    when it exits, even killed, so nothing goes stale). Another worker of this run, or of
    any other run on the machine, skips a held domain and takes the next free one; so two
    test processes never share a domain, whatever their run ids or worker numbers."""

    def __init__(self, lock_dir: Path = DOMAIN_LOCKS, domains: range = TEST_DOMAINS) -> None:
        self.lock_dir, self.domains = lock_dir, domains
        self._held: dict[str, tuple[int, int]] = {}  # user -> (domain, locked descriptor)

    def domain(self, user: str) -> int:
        """``user``'s domain in this process, claimed on the first call."""
        if user not in self._held:
            self._held[user] = self._claim(user)
        return self._held[user][0]

    def _claim(self, user: str) -> tuple[int, int]:
        self.lock_dir.mkdir(parents=True, exist_ok=True)
        with contextlib.suppress(PermissionError):  # another user's folder: theirs to set
            self.lock_dir.chmod(0o1777)
        first = os.getpid() % len(self.domains)  # processes start apart: fewer retries
        for k in range(len(self.domains)):
            domain = self.domains[(first + k) % len(self.domains)]
            fd = self._lock(self.lock_dir / f"{domain}.lock")
            if fd is not None:
                with contextlib.suppress(OSError):  # who holds it, for a reader (not read back)
                    os.ftruncate(fd, 0)
                    os.write(fd, f"pid {os.getpid()} {user}\n".encode())
                return domain, fd
        raise RuntimeError(f"every ROS 2 test domain {self.domains.start}.."
                           f"{self.domains.stop - 1} is held by a live test process "
                           f"(locks in {self.lock_dir})")

    @staticmethod
    def _lock(path: Path) -> int | None:
        """A descriptor of ``path`` holding its exclusive lock, or None if another holds it."""
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
        except PermissionError:  # another user's file (a sticky /tmp): flock needs no write
            try:
                fd = os.open(path, os.O_RDONLY)
            except OSError:
                return None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            return None
        return fd

    def release(self) -> None:
        for _, fd in self._held.values():
            os.close(fd)
        self._held.clear()


_CLAIMS = DomainClaims()


def ros_domain(user: str) -> int:
    """A loopback domain for ``user`` (one of :data:`_DOMAIN_USERS`), this test process's
    own while it lives: no other test process on the machine (another xdist worker of this
    run, or another run's) holds it (:class:`DomainClaims`)."""
    if user not in _DOMAIN_USERS:
        raise ValueError(f"{user!r} is not one of the domain users {_DOMAIN_USERS}")
    return _CLAIMS.domain(user)


@pytest.fixture(scope="session")
def domain_id() -> int:
    return ros_domain("runtime")


@pytest.fixture(params=TRANSPORT_KINDS)
def transport_kind(request: pytest.FixtureRequest) -> str:
    return str(request.param)


def make_transport(kind: str, domain: int, name: str) -> ProcessTransport:
    """A transport as a launch's process makes it (not following /clock)."""
    return ProcessSpec(name, transport=kind, domain_id=domain,
                       use_sim_time=False).make_transport()
