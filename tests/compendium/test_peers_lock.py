"""The peers' bench environment (`make bench-peers`, bench/peers/): its own hash-pinned lock, kept out
of the runtime lock, with every package it shares with the runtime at the runtime's version (so both
sides of a timing run on the same numpy, scipy and jax)."""

from helpers.locks import pins
from mutual.compendium.paths import ROOT

PEERS = ROOT / "bench" / "peers"
PEER_PACKAGES = ("crocoddyl", "casadi", "pingouin")


def test_the_peers_are_pinned_in_their_own_lock_and_never_in_the_runtime_lock():
    peers, runtime = pins(PEERS / "requirements.lock"), pins(ROOT / "environment.lock")
    for name in PEER_PACKAGES:
        assert name in peers, f"bench/peers/requirements.lock lacks {name}"
        assert name not in runtime, f"environment.lock must not hold {name} (the peers' bench only)"
    assert "Python 3.11" in (PEERS / "requirements.lock").read_text()


def test_shared_packages_have_the_runtime_versions():
    peers, runtime = pins(PEERS / "requirements.lock"), pins(ROOT / "environment.lock")
    shared = set(peers) & set(runtime)
    assert {"numpy", "scipy", "jax", "jaxlib", "statsmodels", "pandas"} <= shared
    assert {k: (peers[k], runtime[k]) for k in shared if peers[k] != runtime[k]} == {}
    assert "-c ../../environment.lock" in (PEERS / "requirements.in").read_text()


def test_make_knows_the_peers_environment_and_keeps_it_out_of_git():
    makefile = (ROOT / "Makefile").read_text()
    assert "bench-peers:" in makefile and "lock-peers:" in makefile
    assert "-r bench/peers/requirements.lock" in makefile and "--require-hashes" in makefile
    assert ".venv-peers/" in (ROOT / ".gitignore").read_text().splitlines()
