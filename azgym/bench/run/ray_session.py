"""Reaching Ray for a run: a local instance started here, or a cluster joined, and saying which.

Without an address (or with ``local``) azgym starts its own local instance, whatever
``RAY_ADDRESS`` or a cluster ``ray start`` recorded says; ``auto`` joins the cluster ``ray.init``
would find; a HOST:PORT is checked for its form (:func:`check_address`), then for an answer
within seconds, then joined within :data:`JOIN_TIMEOUT`. A cluster with Ray's token
authentication that refuses azgym is named as such, with what to do (docs/scaling.md).

Ray is imported here only when a session is opened.
"""

from __future__ import annotations

import contextlib
import logging
import os
import socket
import threading
from collections.abc import Callable, Iterator
from typing import Any

from azgym.bench.run.processes import default_workers
from azgym.errors import InvalidInputError, require

__all__ = ["AUTH_MODE", "CONNECT_TIMEOUT", "JOIN_TIMEOUT", "check_address", "ray_session"]

CONNECT_TIMEOUT = 5.0
"""Seconds to reach a cluster's address before ``--address`` is refused (Ray itself would keep
retrying for minutes)."""
JOIN_TIMEOUT = 20.0
"""Seconds ``ray.init`` may take to join the cluster at ``--address`` (joining takes seconds;
with something else listening there, Ray would wait for minutes)."""
AUTH_MODE = "RAY_AUTH_MODE"
"""The variable that turns Ray's token authentication on (``token``) in a process: a cluster
started with it asks every process that joins it for its token."""



@contextlib.contextmanager
def ray_session(address: str | None, workers: int,
                say: Callable[[str], None] | None = None) -> Iterator[int]:
    """Ray, ready to run: the cluster at ``address``, else a local instance started here.

    Without an address (or with ``local``) azgym starts a local instance of ``workers`` CPUs
    (one per core when 0) whatever ``RAY_ADDRESS`` or a cluster ``ray start`` recorded says;
    ``auto`` joins that cluster. ``say`` hears which it is. Yields how many actors run at once
    (``workers``, else the CPUs Ray has). Ray already initialized is used as it is; an
    instance started or joined here is shut down.

    Raises:
        DependencyNotInstalled: Ray is not installed.
        InvalidInputError: Nothing answers at ``address`` (or at the address ``auto`` finds),
            it is not a Ray cluster, or it asks for a token azgym does not have.
    """
    require("ray", "ray")
    import ray

    target = _cluster(address)
    started = not ray.is_initialized()
    if not started:
        where = "the Ray instance already running"
    elif target is None:
        # "local": a new instance even where Ray would join RAY_ADDRESS or a recorded cluster
        ray.init(address="local", num_cpus=workers or default_workers(),
                 include_dashboard=False, logging_level=logging.ERROR)
        where = "a local Ray instance"
    else:
        _join(ray, str(address), target)
        where = f"the cluster at {target}"
    try:
        cpus = int(ray.cluster_resources().get("CPU", 0))
        if say is not None:
            say(f"Ray: {where} ({cpus} CPU{'' if cpus == 1 else 's'})")
        yield workers or max(1, cpus)
    finally:
        if started:
            ray.shutdown()


def _cluster(address: str | None) -> str | None:
    """The address of the cluster to join, checked to answer; None for a local instance.

    ``auto``'s is the one ``ray.init`` would find (:func:`_recorded_cluster`).
    """
    if address in (None, "local"):
        return None
    target = _recorded_cluster() if address == "auto" else str(address)
    if (endpoint := check_address(target)) is not None:
        _probe(str(address), endpoint, target)
    return target


def _recorded_cluster() -> str:
    """The cluster ``--address auto`` joins, found as ``ray.init`` finds it.

    ``RAY_ADDRESS``, else the cluster the last ``ray start`` on this node recorded, else a Ray
    instance running on it.

    Raises:
        InvalidInputError: There is none.
    """
    from ray._private.services import canonicalize_bootstrap_address

    try:
        found = canonicalize_bootstrap_address("auto")
    except (ConnectionError, ValueError) as exc:
        raise InvalidInputError(f"--address auto: no Ray cluster to join ({exc}); start one "
                                "with `ray start --head`, or leave out --address for a local "
                                "instance") from None
    return str(found)


def _join(ray: Any, address: str, target: str) -> None:
    """``ray.init`` on the cluster at ``address`` (found at ``target``) within ``JOIN_TIMEOUT``.

    A HOST:PORT is first asked for its cluster's id, as ``ray health-check`` does, with the
    token ``ray.init`` would give it (for ``auto``, Ray takes the node's token if it has one):
    a cluster that refuses it does so at once, where ``ray.init`` would retry for 20 s,
    printing a warning each time.
    """
    joined: list[BaseException | None] = []

    def join() -> None:
        try:
            if "://" not in target:
                if address == "auto":
                    from ray._private.authentication.authentication_token_setup import (
                        maybe_enable_token_auth_if_token_available,
                    )

                    logging.getLogger("ray").setLevel(logging.ERROR)  # as ray.init will
                    maybe_enable_token_auth_if_token_available(warn_if_disabled=False)
                ray._raylet.GcsClient(address=target)
            ray.init(address=address, logging_level=logging.ERROR)
            joined.append(None)
        except BaseException as exc:  # noqa: BLE001 - reported by the caller's thread
            joined.append(exc)

    thread = threading.Thread(target=join, daemon=True)  # Ray has no deadline for joining
    thread.start()
    thread.join(JOIN_TIMEOUT)
    if not joined:
        raise InvalidInputError(f"--address {address}: something answers there but no Ray "
                                f"cluster joined within {JOIN_TIMEOUT:g} s; is it a head node's "
                                "(`ray start --head` prints it)?")
    if isinstance(exc := joined[0], ray.exceptions.AuthenticationError):
        raise _token_refused(address, target, exc)
    if exc is not None:
        raise InvalidInputError(f"--address {address}: cannot join a Ray cluster there "
                                f"({type(exc).__name__}: {str(exc).splitlines()[0]})")


def _token_refused(address: str, target: str, exc: BaseException) -> InvalidInputError:
    """The cluster at ``target`` asks for a token (Ray's token authentication): what to do."""
    said = str(exc).split(". ")[0].removeprefix("RPC error: ")
    problem = ("refuses the token azgym gave it" if os.environ.get(AUTH_MODE) == "token"
               else "requires token authentication")
    where = "there" if target == address else f"at {target}"
    return InvalidInputError(
        f"--address {address}: the Ray cluster {where} {problem} (Ray: {said}); run azgym with "
        f"{AUTH_MODE}=token and the cluster's token (`ray get-auth-token` on the head node "
        "prints it) in ~/.ray/auth_token or in a file named by RAY_AUTH_TOKEN_PATH "
        "(docs/scaling.md)")


def check_address(address: str | None) -> tuple[str, int] | None:
    """A cluster's address as (host, port), or None for the forms with no address to probe.

    Those are None and ``local`` (azgym starts a local instance sized by ``--workers``) and
    ``auto`` (the cluster ``ray.init`` finds: ``RAY_ADDRESS``, else the one ``ray start`` on the
    node recorded).

    Checked for its form before anything runs (frames drawn, Ray started), so a typo is named
    at once rather than met as a connection that fails.

    Raises:
        InvalidInputError: Not HOST:PORT or ray://HOST:PORT, or a port outside 1-65535.
    """
    if address in (None, "auto", "local"):
        return None
    host, _, port = address.removeprefix("ray://").rpartition(":")
    if not host.strip("[]") or not port.isdigit():
        raise InvalidInputError(f"--address {address}: must be HOST:PORT (a head node's, e.g. "
                                "127.0.0.1:6379), ray://HOST:PORT or auto")
    if not 1 <= int(port) <= 65535:
        raise InvalidInputError(f"--address {address}: invalid port {port}: a port is a whole "
                                "number in 1-65535")
    return host.strip("[]"), int(port)


def _probe(address: str, endpoint: tuple[str, int], target: str) -> None:
    """Refuse, within ``CONNECT_TIMEOUT``, an address where none listens.

    ``endpoint`` is ``target``'s host and port; ``target`` is the address ``auto`` found, else
    ``address`` itself.
    """
    try:
        socket.create_connection(endpoint, CONNECT_TIMEOUT).close()
    except OSError as exc:
        why = exc.strerror or exc
        if address == "auto":
            named = "RAY_ADDRESS names" if os.environ.get("RAY_ADDRESS") else "`ray start` recorded"
            raise InvalidInputError(
                f"--address auto: the cluster {named}, at {target}, does not answer within "
                f"{CONNECT_TIMEOUT:g} s ({why}): it has stopped; start one with `ray start "
                "--head`, or leave out --address for a local instance") from None
        raise InvalidInputError(
            f"--address {address}: no Ray cluster answers there within {CONNECT_TIMEOUT:g} s "
            f"({why}); start one with `ray start --head` and pass the address it prints"
        ) from None
