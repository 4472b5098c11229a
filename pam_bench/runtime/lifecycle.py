"""Managed (lifecycle) nodes: the devices, the drivers and the torque servo on a wall clock.

A node whose settings have the field ``managed`` (``config.settings.ManagedSettings``: the
devices, the drivers, the torque servo) is a ROS 2 lifecycle node when it runs on a wall clock
(``rclpy.lifecycle``, the same state machine and ``~/change_state``, ``~/get_state`` services
as ros2_control's hardware and most driver packages). Its transitions mean:

* **configure**: the settings were declared and checked at construction (structural ones are
  read-only from then on); a driver sets its device up here (``configure_device``: the CAN
  drive's SDO configuration and PDO mapping). A failure is one ERROR diagnostic and the
  transition fails. With ``await_recorder`` (the bring-up sets it when the run records) the
  node first waits, at most ``RECORDER_WAIT_S``, until the run's recorder subscribes to
  ``/diagnostics`` and its own publisher has matched every subscription the graph shows
  there: the transitions' diagnostics are then in the bag, however slow discovery was (a
  manager may call before the recorder has matched a process that has just started);
* **activate**: the node starts stepping (``on_wall_tick``); a controller's start gate counts
  from here (the torque servo's ``startup_timeout_s`` for its inputs starts at its first
  active tick, however long its manager took);
* **deactivate**: its outputs go to their safe state at once (``safe_state``: valves vented,
  the drive off, the servo's valves vented), it publishes what it measures there
  (``publish_safe_state``: the vented valve's pressure) and it stops stepping;
* a transition the present state does not have (``activate`` on an active node) is refused:
  the service answers ``success: false`` and a WARN diagnostic names it, the node goes on
  (rclpy's own service would raise and end the process);
* **cleanup** and **shutdown**: as deactivate, from any state.

With ``managed: false`` (the default, a node started by hand) the node configures and
activates itself at its first tick; with ``managed: true`` it waits, unconfigured, for a
manager: the wall-clock bring-up (``bringup.lifecycle``) or ``ros2 lifecycle set``. In
lock-step a node is not managed: the sim clock gates it (``runtime.lockstep``), and its
readings stay those of every earlier run.
"""

from __future__ import annotations

import functools
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.lifecycle import LifecycleNodeMixin, LifecycleState, TransitionCallbackReturn

from pam_bench.config import topics
from pam_bench.runtime.core import NodeCore

__all__ = ['Lifecycle', 'SUCCESS', 'FAILURE', 'RECORDER_WAIT_S']

SUCCESS = TransitionCallbackReturn.SUCCESS
FAILURE = TransitionCallbackReturn.FAILURE
RECORDER_WAIT_S = 10.0
"""The most a configure waits for the run's recorder on ``/diagnostics`` (s); past it the node
configures anyway and says so (WARN)."""


class Lifecycle(NodeCore, LifecycleNodeMixin):
    """The lifecycle of a managed node (module docstring)."""

    def _init_lifecycle(self) -> None:
        # a node whose settings carry ``managed`` (a device, a driver, the torque servo) is
        # a lifecycle node on a wall clock
        self.managed = hasattr(self.settings, 'managed') and not self.lockstep
        self.active = not self.managed               # unmanaged nodes step from the start
        self._awaits_manager = self.managed and bool(getattr(self.settings, 'managed', False))
        if self.managed:
            LifecycleNodeMixin.__init__(self, enable_communication_interface=True)
            service = self._service_change_state
            service.callback = functools.partial(self._guarded_change, service.callback)

    def _guarded_change(self, change: Any, req: Any, resp: Any) -> Any:
        """``~/change_state``, refusing a transition the present state lacks (one WARN
        diagnostic; rclpy's own raises ``RCLError`` and the process ends) and never letting
        an exception out."""
        available = {t[0]: t[1] for t in self._state_machine.available_transitions}
        asked = req.transition.label or str(req.transition.id)
        if (req.transition.label and req.transition.label not in available.values()) or \
                (not req.transition.label and req.transition.id not in available):
            self.diagnose(DiagnosticStatus.WARN, f'transition {asked!r} refused in state '
                          f'{self.lifecycle_state} (available: '
                          f'{", ".join(sorted(set(available.values()))) or "none"})',
                          'lifecycle')
            resp.success = False
            return resp
        try:
            return change(req, resp)
        except Exception as exc:  # noqa: BLE001 - a service must not end the node
            self.diagnose(DiagnosticStatus.ERROR, f'transition {asked!r} failed: {exc}',
                          'lifecycle')
            resp.success = False
            return resp

    @property
    def lifecycle_state(self) -> str:
        """'unconfigured', 'inactive', 'active', 'finalized' (or a transition's name); an
        unmanaged node is always 'active'."""
        if not self.managed:
            return 'active'
        return str(self._state_machine.current_state[1])

    def may_step(self) -> bool:
        """Whether the node steps now: active; a managed node that does not wait for a
        manager configures and activates itself at its first tick."""
        if self.active:
            return True
        if self.managed and not self._awaits_manager and \
                self.lifecycle_state == 'unconfigured':
            self._awaits_manager = True              # once: a failed configure stays failed
            if self.trigger_configure() == SUCCESS:
                self.trigger_activate()
            else:
                self.exit_code = 2                   # it cannot run: its diagnostic says why
        return self.active

    # --- to override ---------------------------------------------------------------------
    def configure_device(self) -> str:
        """Set the device up (a driver's bus configuration); returns why it failed ('':
        it did not)."""
        return ''

    def safe_state(self) -> None:
        """Put the node's outputs in their safe state now (valves vented, the drive off)."""

    def publish_safe_state(self) -> None:
        """Publish what the node measures in the safe state it leaves (a vented valve's
        pressure), so that its last message is not the one before the transition."""

    # --- the transitions ----------------------------------------------------------------
    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Configure: the device set up (module docstring)."""
        if getattr(self.settings, 'await_recorder', False) and not self._recorder_matched():
            self.diagnose(DiagnosticStatus.WARN, 'no recorder on '
                          f'{self.resolve_topic_name(topics.DIAGNOSTICS)} within '
                          f'{RECORDER_WAIT_S:g} s: configuring anyway', 'recorder')
        why = self.configure_device()
        if why:
            self.diagnose(DiagnosticStatus.ERROR, f'configure failed: {why}', 'lifecycle')
            return FAILURE
        self.diagnose(DiagnosticStatus.OK, 'configured', 'lifecycle')
        return SUCCESS

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Activate: stepping starts."""
        self.active = True
        self.diagnose(DiagnosticStatus.OK, 'active', 'lifecycle')
        return SUCCESS

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Deactivate: the outputs safe, stepping stops."""
        self._stop_stepping('inactive: outputs safe')
        return SUCCESS

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Cleanup: as deactivate."""
        self._stop_stepping('unconfigured: outputs safe')
        return SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Shutdown: as deactivate."""
        self._stop_stepping('finalized: outputs safe')
        return SUCCESS

    def on_error(self, state: LifecycleState) -> TransitionCallbackReturn:
        """An error in a transition: outputs safe; back to unconfigured."""
        self._stop_stepping('error in a transition: outputs safe')
        return SUCCESS

    def _recorder_matched(self) -> bool:
        """Wait (at most ``RECORDER_WAIT_S``) until the recorder subscribes to the diagnostics
        and this node's publisher has matched every subscription there (module docstring)."""
        pub = getattr(self._diag_pub, 'dds', self._diag_pub)   # past an intra-process bus
        topic = self.resolve_topic_name(topics.DIAGNOSTICS)
        end = time.monotonic() + RECORDER_WAIT_S
        while True:
            try:
                if self.recorder_listens(topics.DIAGNOSTICS) and pub.get_subscription_count() \
                        >= len(self.get_subscriptions_info_by_topic(topic)):
                    if pub is not self._diag_pub:      # an intra-process bus publisher looks
                        self._diag_pub.external = True  # for outside readers every 50 ms
                    return True
            except Exception:  # noqa: BLE001 - a graph query must not end a transition
                pass
            if time.monotonic() > end:
                return False
            time.sleep(0.01)

    def _stop_stepping(self, text: str) -> None:
        self.active = False
        try:
            self.safe_state()
            self.publish_safe_state()
        except Exception as exc:  # noqa: BLE001 - a transition must never let an exception out
            self.diagnose(DiagnosticStatus.ERROR, f'safe state failed: {exc}', 'lifecycle')
            return
        self.diagnose(DiagnosticStatus.WARN if text.startswith('inactive') else
                      DiagnosticStatus.OK, text, 'lifecycle')
