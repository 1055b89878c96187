"""A DDS participant that speaks ROS 2: domains, the loopback network, and ROS 2's QoS.

* **Network**: ``"loopback"`` (the default) configures Cyclone DDS for this machine only:
  the ``lo`` interface, no multicast, the peer ``127.0.0.1``; redservo then never sends a
  packet to another address (the rehearsal arm and the tests use it). ``"system"`` uses
  Cyclone's own configuration (the ``CYCLONEDDS_URI`` environment variable, as ROS 2 does):
  use it for an arm on another machine.
* **QoS** as ROS 2's defaults: :data:`SENSOR_DATA` (best effort, keep last 5, volatile:
  ``rclcpp::SensorDataQoS``) for what redservo reads (a best-effort reader also matches a
  reliable publisher such as ``joint_state_broadcaster``), :data:`COMMANDS` (reliable, keep
  last 10, volatile: ``rclcpp::SystemDefaultsQoS``) for what it publishes.
* **Domain id**: 0–232 (``ROS_DOMAIN_ID``'s range on Linux).
"""

from __future__ import annotations

from typing import Any, Literal

from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from redservo.errors import ConfigurationError
from redservo.ros2.naming import dds_topic

__all__ = ["COMMANDS", "LOOPBACK_CONFIG", "MAX_DOMAIN_ID", "SENSOR_DATA", "Network", "Ros2Node"]

Network = Literal["loopback", "system"]
MAX_DOMAIN_ID = 232
"""The largest ROS 2 domain id (Linux)."""

SENSOR_DATA = Qos(
    Policy.Reliability.BestEffort, Policy.History.KeepLast(5), Policy.Durability.Volatile
)
"""ROS 2's sensor-data QoS: for joint states, images and camera info."""
COMMANDS = Qos(
    Policy.Reliability.Reliable(max_blocking_time=100_000_000),
    Policy.History.KeepLast(10),
    Policy.Durability.Volatile,
)
"""ROS 2's default QoS (reliable): for velocity commands."""

LOOPBACK_CONFIG = """<CycloneDDS><Domain Id="any"><General>
<Interfaces><NetworkInterface name="lo"/></Interfaces><AllowMulticast>false</AllowMulticast>
</General><Discovery><ParticipantIndex>auto</ParticipantIndex>
<MaxAutoParticipantIndex>40</MaxAutoParticipantIndex>
<Peers><Peer address="127.0.0.1"/></Peers></Discovery></Domain></CycloneDDS>"""
"""Cyclone DDS on the loopback interface only (no multicast, unicast discovery on localhost)."""

_DOMAINS: dict[int, tuple[Network, Domain | None]] = {}


def _domain(domain_id: int, network: Network) -> None:
    """Create the process's domain ``domain_id`` on ``network`` once (Cyclone allows one)."""
    if domain_id in _DOMAINS:
        if _DOMAINS[domain_id][0] != network:
            raise ConfigurationError(
                f"domain {domain_id} is already open on the {_DOMAINS[domain_id][0]} network "
                f"in this process; cannot reopen it on {network}",
                argument="network",
            )
        return
    config = LOOPBACK_CONFIG if network == "loopback" else None
    _DOMAINS[domain_id] = (network, Domain(domain_id, config) if config else None)


class Ros2Node:
    """A DDS participant on a ROS 2 domain, with ROS-named readers and writers.

    Args:
        domain_id: The ROS 2 domain (``ROS_DOMAIN_ID``), 0–232.
        network: ``"loopback"`` (this machine only) or ``"system"`` (``CYCLONEDDS_URI``).

    Raises:
        ConfigurationError: ``domain_id`` or ``network`` is out of range.
    """

    def __init__(self, domain_id: int = 0, *, network: Network = "loopback") -> None:
        if isinstance(domain_id, bool) or not isinstance(domain_id, int):
            raise ConfigurationError(
                f"domain_id must be an integer 0-{MAX_DOMAIN_ID}, got {domain_id!r}",
                argument="domain_id",
            )
        if not 0 <= domain_id <= MAX_DOMAIN_ID:
            raise ConfigurationError(
                f"domain_id must be 0-{MAX_DOMAIN_ID} (ROS_DOMAIN_ID), got {domain_id}",
                argument="domain_id",
            )
        if network not in ("loopback", "system"):
            raise ConfigurationError(
                f"network must be 'loopback' or 'system', got {network!r}", argument="network"
            )
        _domain(domain_id, network)
        self.domain_id = domain_id
        self.network = network
        self.participant: DomainParticipant | None = DomainParticipant(domain_id)
        self._topics: dict[str, Topic] = {}

    def _open(self) -> DomainParticipant:
        if self.participant is None:
            raise ConfigurationError("this ROS 2 node is closed", argument="node")
        return self.participant

    def _topic(self, name: str, cls: type) -> Topic:
        if name not in self._topics:
            self._topics[name] = Topic(self._open(), dds_topic(name), cls)
        return self._topics[name]

    def reader(self, topic: str, cls: type, qos: Qos = SENSOR_DATA) -> Any:
        """A reader of the ROS 2 topic ``topic`` (fully qualified) with messages ``cls``."""
        return DataReader(self._open(), self._topic(topic, cls), qos=qos)

    def writer(self, topic: str, cls: type, qos: Qos = COMMANDS) -> Any:
        """A writer to the ROS 2 topic ``topic`` (fully qualified) with messages ``cls``."""
        return DataWriter(self._open(), self._topic(topic, cls), qos=qos)

    def close(self) -> None:
        """Delete the participant and everything it created (safe to call twice)."""
        self._topics.clear()
        self.participant = None  # cyclonedds deletes the entity when it is collected
