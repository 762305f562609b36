"""Fixtures shared across test modules."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path

import pytest

from spine_module.messages import channels
from tests import lcm_mark
from tests.node_netns import PERIOD, UDP_COUNTERS, K, lcm_tool, run_in_netns

ROOT = Path(__file__).resolve().parents[1]
INTEGRATION = ROOT / "tests" / "integration"


def pytest_collection_modifyitems(config, items):
    """Everything under tests/integration/ (several processes, sockets, namespaces, or a whole workflow end
    to end: seconds per test) carries the `integration` marker, so `-m "not integration"` is the unit tier
    and a test's tier is where it lives; a unit module marks a single slow test itself."""
    for item in items:
        if INTEGRATION in Path(item.fspath).parents:
            item.add_marker(pytest.mark.integration)


AUTHORS_REPO_ENV = "SPARC_AUTHORS_REPO"


@pytest.fixture(scope="session")
def authors_repo() -> Path:
    """A git checkout of the SPARC authors' repository, for the reproduction tier (`make test-reproduction`):
    the tests that compare against their files fail, never skip, without it."""
    import os

    path = os.environ.get(AUTHORS_REPO_ENV)
    if not path or (not (Path(path) / ".git").exists() and not (Path(path) / "HEAD").exists()):
        pytest.fail(f"the reproduction tier needs the SPARC authors' repository: "
                    f"git clone https://github.com/YueWang996/sparc /some/folder, then "
                    f"{AUTHORS_REPO_ENV}=/some/folder make test-reproduction "
                    f"(got {AUTHORS_REPO_ENV}={path!r})")
    return Path(path)


@pytest.fixture(scope="session")
def lcm_run(tmp_path_factory):
    """A recorded node session: `spine-node` + `bench-robot` (static push-pull, k_x = K, one PERIOD) +
    `lcm-logger`, as separate processes on UDP multicast in a network namespace. Returns (folder, logs).
    The robot starts once the logger records a start mark and the logger stops once it records an end
    mark (tests/lcm_mark.py); the namespace's UDP counters are kept (udp_snmp.txt) so that a test can
    tell datagrams the kernel dropped at a full buffer from datagrams lost any other way."""
    out = tmp_path_factory.mktemp("lcm_run")
    py = shlex.quote(sys.executable)
    # the logger gets the largest receive buffer the namespace allows (net.core.rmem_max, 4 MiB here) and,
    # where the caller may raise priorities (root), a higher one: at load it is the process most likely to
    # be descheduled long enough for its socket to overflow (seen: 86 of 2000 feedback datagrams lost)
    url = shlex.quote(channels.DEFAULT_URL.replace("recv_buf_size=2097152", "recv_buf_size=4194304"))
    exp = f"--experiment static --kx {K} --period {PERIOD} --cycles 1"
    script = f"""
export PYTHONPATH={shlex.quote(str(ROOT))}
{py} -m sparc_quad spine-node --motors lcm --clock lockstep --idle-timeout 2 --soft-start 0 \
    --summary {out}/node.json > {out}/node.out 2> {out}/node.err &
NODE=$!
NICE=""; [ "$(nice -n -5 nice 2>/dev/null)" = "-5" ] && NICE="nice -n -5"  # only where it takes effect
$NICE {shlex.quote(lcm_tool("lcm-logger"))} -q --lcm-url={url} -f {out}/session.lcmlog \
    > {out}/logger.out 2>&1 &
LOGGER=$!
{py} -m tests.lcm_mark {url} {lcm_mark.START} {out}/session.lcmlog 2> {out}/mark.err
{py} -m sparc_quad bench-robot --clock lockstep {exp} --out {out} > {out}/robot.out 2> {out}/robot.err
wait $NODE
{py} -m tests.lcm_mark {url} {lcm_mark.END} {out}/session.lcmlog 2>> {out}/mark.err
kill -INT $LOGGER
wait $LOGGER || true
""" + UDP_COUNTERS.format(out=out)
    r = run_in_netns(script, ROOT)
    logs = "\n".join(f"--- {p.name}\n{p.read_text()[-3000:]}" for p in sorted(out.glob("*.err")))
    assert r.returncode == 0, f"rc={r.returncode}\n{r.stderr}\n{logs}"
    return out, logs
