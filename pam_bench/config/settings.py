"""Every node's settings as one typed dataclass: the one owner of each default, unit and range.

A node's settings are its own fields plus the parameter sets of the models it runs, as
sections (``valve``, ``muscle``, ``straight_fibre``, ``load_cell``, ``encoder``, ``servo``).
The scene loader builds them (defaults, then config/bench.yaml, an overlay, the scene), the
bring-up serialises them into a params file, each node declares its ROS parameters from the
same class (``runtime.params.declare_settings``), and the twin, truth, servo-compare and sweeps
read the objects. A leaf is addressed by its path, ``muscle_1.muscle.gain_exponent``.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from pam_bench.control.torque_servo import ServoMode, SignalKind, TorqueServoParams
from pam_bench.models.constants import PULLEY_PITCH_DIAMETER_M, SUB_STEP_S
from pam_bench.models.coupling import SettleParams
from pam_bench.models.loading_servo import LoadingServoParams
from pam_bench.models.loading_servo.units import DriveScale
from pam_bench.models.muscle import MuscleParams
from pam_bench.models.sensors import EncoderParams, LoadCellParams
from pam_bench.models.straight_fibre_muscle import StraightFibreParams
from pam_bench.models.valve import ValveParams
from pam_bench.protocol.settings import RunnerSettings
from pam_bench.vocabulary.params import field, section

__all__ = ['NodeSettings', 'DeviceSettings', 'ControllerSettings', 'ClockSettings',
           'ValveSettings', 'MuscleSettings', 'LoadCellSettings', 'EncoderSettings',
           'LoadingServoSettings', 'SequencerSettings', 'TorqueServoSettings',
           'RecorderSettings', 'LiveViewSettings', 'LIVE_FULL_RATE_TOPICS', 'ManagedSettings',
           'RecordedSettings', 'InitialLoadSettings', 'RealtimeSettings']


@dataclasses.dataclass
class NodeSettings:
    """What every bench node takes: how it steps and where its statistics go."""

    lockstep: bool = field(True, '-', 'step on /clock ticks in lock-step with sim_clock')
    stats_file: str = field('', '-', 'write the DDS publish counts and the wall-clock tick '
                            'statistics here at the end (JSON)')
    hardware_id: str = field('', '-', "REP-107 hardware_id of the node's diagnostics ('': "
                             'pam_bench/NODE)')
    diagnostics_period_s: float = field(1.0, 's', 'period of the diagnostics summary (sim '
                                        'time in lock-step, wall time otherwise; 0: none)',
                                        0.0, 3600.0, tunable=True)


@dataclasses.dataclass
class RecordedSettings:
    """A node whose first words on a wall clock the run's recorder must not miss."""

    await_recorder: bool = field(False, '-', "without lock-step: start only once the run's "
                                 'recorder has subscribed, so that nothing goes unrecorded (a '
                                 "controller's first command; a managed node's configure, so "
                                 'the bag holds its lifecycle transitions)')


@dataclasses.dataclass
class ManagedSettings(RecordedSettings):
    """A lifecycle node on a wall clock (``runtime.lifecycle``): a device, a driver, the
    torque servo."""

    managed: bool = field(False, '-', 'wall clock: come up unconfigured and wait for a '
                          'lifecycle manager (the bring-up, ros2 lifecycle set) instead of '
                          'configuring and activating itself at its first tick')


@dataclasses.dataclass
class DeviceSettings(NodeSettings, ManagedSettings):
    """A simulated device: its rate on a wall clock and the faults injected into it."""

    rate_hz: float = field(1000.0, 'Hz', 'update rate on a wall clock (lockstep false)',
                           1.0, 10000.0)
    faults_yaml: str = field('', '-', "wall clock: faults injected into this device (YAML "
                             "list, sim.faults; from a scene's faults)")


@dataclasses.dataclass
class ControllerSettings(NodeSettings, RecordedSettings):
    """A node that reads the measured topics and commands the valves (sequencer, servo)."""

    startup_timeout_s: float = field(30.0, 's', 'without lock-step: exit (code 3) when a '
                                     'measured topic has not come this long after start',
                                     0.1, 3600.0)
    joint_name: str = field('pulley', '-', 'the joint of encoder/joint_state the node reads (by '
                            'name: a driver may publish several joints)')


@dataclasses.dataclass
class ValveSettings(DeviceSettings):
    """valve_sim."""

    channel: int = field(1, '-', 'muscle channel N', 1, 2)
    sync_command: bool = field(True, '-', 'require a command at every step (lock-step '
                               'controllers)')
    sub_step_s: float = field(SUB_STEP_S, 's', 'sub-step of the pressure samples the muscle '
                              'follows (the record sample period replaces it during a record)',
                              1e-5, 1.0)
    valve: ValveParams = section(ValveParams, 'the valve model (models.valve)')


def _law_settings() -> type:
    """A settings dataclass with one section per force law the bench can hold (the zoo's and
    the plug-ins', ``models.laws.zoo.all_laws``), named by the law: ``laws.LAW.PARAMETER``."""
    from pam_bench.models.laws.zoo import all_laws
    fields = [(law.name, law.settings, section(law.settings, f'{law.name} ({law.seed})'))
              for law in all_laws()]
    cls = dataclasses.make_dataclass('LawSettings', fields)
    cls.__module__ = __name__
    cls.__doc__ = 'The parameters of every force law, by law (models.laws).'
    return cls


LawSettings = _law_settings()


@dataclasses.dataclass
class MuscleSettings(DeviceSettings):
    """muscle_sim."""

    channel: int = field(1, '-', 'muscle channel N', 1, 2)
    muscle: MuscleParams = section(MuscleParams, 'the McKibben muscle (models.muscle) and '
                                   'which law the bench holds (kind)')
    straight_fibre: StraightFibreParams = section(
        StraightFibreParams, "000's straight-fibre muscle, used when muscle.kind is "
        'straight_fibre (models.straight_fibre_muscle)')
    settle: SettleParams = section(SettleParams, 'when a settled muscle is held for the rest '
                                   'of an exchange (models.coupling)')
    laws: Any = section(LawSettings, 'the parameters of every force law the bench can hold '
                        '(muscle.kind law, muscle.law names it; models.laws, plug-ins too)')


@dataclasses.dataclass
class LoadCellSettings(DeviceSettings):
    """load_cell_sim."""

    channel: int = field(1, '-', 'muscle channel N', 1, 2)
    seed: int = field(0, '-', "seed of the noise generator (the run's --seed, + channel - 1)",
                      0, 2**31 - 1)
    load_cell: LoadCellParams = section(LoadCellParams, 'the load cell (models.sensors)')


@dataclasses.dataclass
class EncoderSettings(DeviceSettings):
    """encoder_sim."""

    encoder: EncoderParams = section(EncoderParams, 'the pulley encoder (models.sensors)')


@dataclasses.dataclass
class RealtimeSettings:
    """A loop on the wall clock that may run ahead of ordinary processes: the torque servo's
    control loop and the bus drivers' exchanges (``runtime.scheduling.set_realtime_priority``)."""

    realtime_priority: int = field(0, '-', 'without lock-step: run the loop SCHED_FIFO at this '
                                   'priority where allowed (0: off)', 0, 99)


@dataclasses.dataclass
class InitialLoadSettings:
    """The load a drive holds from t_0 until its first command (scenes without a sequencer:
    the torque servo's, whose drive holds the pulley): the simulated loading servo's and the
    CANopen driver's."""

    initial_mode: int = field(0, '-', 'LoadCommand mode held until the first command: 0 off, '
                              '1 force, 2 position', 0, 2)
    initial_setpoint: float = field(0.0, '', 'set value of initial_mode (N or m)', -10.0, 1e4)


@dataclasses.dataclass
class LoadingServoSettings(DeviceSettings, InitialLoadSettings):
    """loading_servo_sim."""

    channel: int = field(1, '-', 'muscle channel on the belt', 1, 2)
    sync_command: bool = field(True, '-', 'require a command at every step (lock-step '
                               'controllers)')
    muscles: int = field(1, '-', 'muscles on the belt: 1 (characterisation) or 2 (antagonistic '
                         'pair, angle held)', 1, 2)
    hold_angle_rad: float = field(0.0, 'rad', 'pulley angle held with two muscles',
                                  -1.0472, 1.0472)
    rest_contraction_m: float = field(0.04, 'm', 'contraction x0 of both muscles at theta = 0 '
                                      '(two muscles)', 0.0, 0.15)
    servo: LoadingServoParams = section(LoadingServoParams, 'the loading drive '
                                        '(models.loading_servo)')


@dataclasses.dataclass
class SequencerSettings(ControllerSettings, RunnerSettings, RealtimeSettings):
    """sequencer: the protocol it runs and the runner's policies (``protocol.settings``)."""

    channel: int = field(1, '-', 'muscle channel under test', 1, 2)
    protocol: str = field('demo', '-', 'protocol started at t_0 with autostart')
    autostart: bool = field(True, '-', 'start the protocol at t_0 (else: on a goal)')
    protocols_file: str = field('', '-', 'YAML file of the protocols (empty: '
                                'config/protocols.yaml)')
    protocol_overrides_yaml: str = field('', '-', 'YAML mapping merged over the autostart '
                                         'protocol (e.g. a coarser grid)')
    tick_period_s: float = field(0.001, 's', 'tick period without lock-step', 1e-4, 1.0)
    resume_from_reading: int = field(0, '-', 'start the autostart protocol at this reading '
                                     '(pam-bench run --resume: the first one a previous bag '
                                     'lacks), approached along its series path', 0, 10**7)
    pitch_diameter_m: float = field(PULLEY_PITCH_DIAMETER_M, 'm', 'pulley pitch diameter for '
                                    'x = r theta', 1e-3, 10.0)


def _controller_plugin_settings() -> type:
    """A settings dataclass with one section per controller plug-in installed here
    (``control.plugins``), named by the plug-in: ``plugins.NAME.FIELD``."""
    from pam_bench.control.plugins import controller_plugins
    fields = [(name, cls.settings, section(cls.settings, f'controller plug-in {name}'))
              for name, cls in controller_plugins().items()]
    cls = dataclasses.make_dataclass('ControllerPluginSettings', fields)
    cls.__module__ = __name__
    cls.__doc__ = 'The settings of every controller plug-in, by plug-in (control.plugins).'
    return cls


ControllerPluginSettings = _controller_plugin_settings()
def _controller_names() -> tuple[str, ...]:
    """The built-in controllers, then every controller plug-in installed here (a broken one
    too: a scene naming it is refused with the reason, ``control.plugins.check_controller``,
    not as an unknown name)."""
    from pam_bench.control.plugins import GROUP
    from pam_bench.vocabulary.plugins import discover
    return (*(m.value for m in ServoMode),
            *dict.fromkeys(p.name for p in discover(GROUP) if p.name not in
                           {m.value for m in ServoMode}))


CONTROLLERS = _controller_names()
"""Every controller the torque servo may be given: the built-ins, then the plug-ins."""


@dataclasses.dataclass
class TorqueServoSettings(ControllerSettings, ManagedSettings, RealtimeSettings):
    """torque_servo: the set point, the controller and the control loop."""

    muscles: int = field(2, '-', 'muscles driven: 2 (torque, N m) or 1 (force, N)', 1, 2)
    controller: str = field(ServoMode.DYNAMIC.value, '-', 'dynamic_inverse_pid, '
                            'static_inverse_pid, pid, the inverse model alone: '
                            'dynamic_inverse, static_inverse (004 Fig. 17), or a plug-in '
                            '(pam-bench plugins)', choices=CONTROLLERS)
    inverse_model_file: str = field('', '-', 'inverse_model.yaml from pam-bench extract '
                                    '(needed by the inverse-model controllers; relative to the '
                                    'repository or install share)')
    signal: str = field(SignalKind.SINE.value, '-', 'set point waveform',
                        choices=tuple(k.value for k in SignalKind), tunable=True)
    amplitude: float = field(5.0, '', 'set point amplitude (N m, or N with one muscle)',
                             -1e4, 1e4, tunable=True)
    omega_rad_s: float = field(1.0, 'rad/s', 'sine angular frequency', 0.0, 1e3, tunable=True)
    offset: float = field(0.0, '', 'set point offset (N m, or N)', -1e4, 1e4, tunable=True)
    period_s: float = field(3.0, 's', 'square-wave period', 1e-3, 1e4, tunable=True)
    control_period_s: float = field(0.001, 's', 'control period without lock-step', 1e-4, 1.0)
    stale_timeout_s: float = field(0.05, 's', 'vent when a measured topic is older than this '
                                   '(without lock-step)', 1e-3, 60.0, tunable=True)
    wall_loop: str = field('deadline', '-', 'without lock-step: run the control loop on a '
                           "monotonic deadline ('deadline') or on rclpy's timer and executor "
                           "('timer', to compare)", choices=('deadline', 'timer'))
    latch_faults: bool = field(True, '-', 'without lock-step: a stale or non-finite measurement '
                               'keeps the valves vented until torque_servo/reset, even when the '
                               'data come back')
    duration_s: float = field(0.0, 's', 'without lock-step: exit this long after the first '
                              'control step (0: run until stopped)', 0.0, 1e6)
    servo: TorqueServoParams = section(TorqueServoParams, 'the controller (control.torque_servo)')
    plugins: Any = section(ControllerPluginSettings, 'the settings of each controller plug-in '
                           '(control.plugins), used when controller names it')


@dataclasses.dataclass
class RecorderSettings(NodeSettings):
    """recorder: where and what it records."""

    out_dir: str = field('bags/run', '-', 'bag directory to create')
    step_topics: list = field(['/clock:rosgraph_msgs/msg/Clock'], '-', 'topic:type recorded in '
                              'lock-step (every step)', item=str)
    event_topics: list = field(['/diagnostics:diagnostic_msgs/msg/DiagnosticArray'], '-',
                               'topic:type recorded as they come', item=str)
    record_all: bool = field(False, '-', 'record every topic that appears (wall clock only; '
                             'like ros2 bag -a)')
    flush_period_s: float = field(1.0, 's', 'close the pending chunk and write it to disk at '
                                  'least this often (wall-clock seconds, lock-step too): what '
                                  'a SIGKILL can lose', 0.01, 3600.0)
    run_yaml: str = field('', '-', "how the run was made (YAML, from the runner): stored in the "
                          "bag's custom data")
    end_file: str = field('', '-', 'JSON of how the run ended, written by the runner before it '
                          'stops the recorder')
    topic_names: list = field([], '-', 'wall clock: record these topics (names; their types are '
                              'discovered) besides step_topics and event_topics', item=str)
    discovery_period_s: float = field(0.5, 's', 'wall clock: look for new topics and '
                                      "publishers' QoS this often", 0.05, 60.0)
    compress: bool = field(True, '-', 'zstd-compress the MCAP chunks (rosbag2 storage mode)')
    max_bag_size_bytes: int = field(900_000_000, 'B', 'start a new file of the bag past this '
                                    'size (0: never); the default keeps each under 1 GB',
                                    100_000, 1e15, off=0)
    max_bag_duration_s: float = field(0.0, 's', 'start a new file of the bag once one spans '
                                      'this much log time (0: never)', 1.0, 1e9, off=0.0)
    min_free_bytes: int = field(64_000_000, 'B', 'stop recording and close the bag valid when '
                                'its disk has less than this free (0: write until it fails)',
                                0, 1e15)


LIVE_FULL_RATE_TOPICS = ['/protocol/point', '/protocol/status', '/protocol/step_response',
                         '/diagnostics']


@dataclasses.dataclass
class DriverSettings(NodeSettings, ManagedSettings, RealtimeSettings):
    """A driver of real hardware on a field bus (``buses``): it runs on the wall clock only."""

    lockstep: bool = field(False, '-', 'drivers run on the wall clock only: keep false')
    rate_hz: float = field(1000.0, 'Hz', 'bus exchanges per second (one read and one write '
                           'each)', 1.0, 10000.0)


@dataclasses.dataclass
class DaqModbusSettings(DriverSettings):
    """daq_modbus: the valves' voltages, their pressures, the load cells and the encoder
    through a Modbus TCP DAQ (``buses.register_map``, ``buses.modbus_io``)."""

    host: str = field('127.0.0.1', '-', "the DAQ's address")
    port: int = field(502, '-', 'its Modbus TCP port', 1, 65535)
    register_map: str = field('daq_generic', '-', 'register map file (a bare name: '
                              'config/buses/NAME.yaml; labjack_t7 is shipped too)')
    timeout_s: float = field(0.05, 's', 'a request that takes longer counts as a lost '
                             'connection (outputs safe, inputs stale, reconnect)', 1e-3, 10.0)
    reconnect_max_s: float = field(2.0, 's', 'longest wait between reconnection attempts '
                                   '(doubling from 0.1 s)', 0.1, 60.0)
    joint_name: str = field('pulley', '-', 'name of the encoder joint it publishes')


@dataclasses.dataclass
class ServoCanopenSettings(DriverSettings, InitialLoadSettings):
    """servo_canopen: the loading servo's CiA 402 drive on CAN (``buses.canopen_drive``)."""

    can_interface: str = field('socketcan', '-', "python-can interface: socketcan (a lab's "
                               'can0) or socketcand (the hub of pam-bench emulate --buses on '
                               '127.0.0.1: buses.can_hub)', choices=('socketcan', 'socketcand'))
    can_channel: str = field('can0', '-', 'CAN channel (interface) name')
    can_port: int = field(29536, '-', 'socketcand: TCP port of the hub on 127.0.0.1', 1, 65535)
    node_id: int = field(5, '-', "the drive's CANopen node id", 1, 127)
    eds_file: str = field('', '-', "the drive's EDS ('': config/buses/loading_servo.eds, the "
                          'emulated drive)')
    heartbeat_ms: int = field(100, 'ms', 'heartbeat period asked of the drive (0x1017)', 10,
                              10000)
    heartbeat_timeout_s: float = field(0.35, 's', 'no heartbeat this long: the drive is stale '
                                       '(diagnostic), then quick stop', 0.01, 60.0)
    channel: int = field(1, '-', 'muscle channel on the belt', 1, 2)
    rate_hz: float = field(250.0, 'Hz', 'PDO cycles per second (the drive closes its force and '
                           'position loops itself; the cycle carries set values and actuals)',
                           1.0, 10000.0)
    drive: DriveScale = section(DriveScale, "the drive's units (buses.cia402)")


@dataclasses.dataclass
class LiveViewSettings:
    """live_view: the bench's topics served to Foxglove (``live.server``)."""

    host: str = field('127.0.0.1', '-', 'address the server binds (127.0.0.1: this machine '
                      'only; 0.0.0.0: every interface)')
    port: int = field(8765, '-', 'TCP port of the server (0: any free one)', 0, 65535)
    max_rate_hz: float = field(50.0, 'Hz', 'send each topic at most this often (0: every '
                               'message), but full_rate_topics', 0.0, 100000.0)
    full_rate_topics: list = field(list(LIVE_FULL_RATE_TOPICS), '-', 'topics always sent whole '
                                   "(the characteristic's points, the status)", item=str)
    topics: list = field([], '-', 'topic:type served (the recorder topics of the scene, '
                         'without /clock and /sim/)', item=str)
    niceness: int = field(10, '-', "scheduling niceness added to the view's process: on a "
                          "busy machine the bench's own nodes get the CPU first", 0, 19)


@dataclasses.dataclass
class ClockSettings:
    """sim_clock: the lock-step master."""

    exchange_step_s: float = field(0.01, 's', 'exchange step h', 1e-6, 10.0)
    participants: list = field([], '-', 'fully qualified names that step in lock-step',
                               item=str)
    duration_s: float = field(0.0, 's', 'stop at this sim time (0: on protocol end)', 0.0, 1e9)
    realtime: bool = field(False, '-', 'pace the ticks to the wall clock')
    grace_s: float = field(0.3, 's', 'wall time between ready and the first step', 0.0, 60.0)
    progress_period_s: float = field(2.0, 's', 'wall time between progress lines', 0.0, 3600.0)
    nudge_s: float = field(1.0, 's', 'publish a tick again, and again, each time it has not '
                           'been acknowledged for this wall time (a message lost at start-up)',
                           0.01, 3600.0)
    summary_file: str = field('', '-', 'write the run summary here as JSON (empty: print it '
                              'only)')
    stall_timeout_s: float = field(10.0, 's', 'abort when a step is not acknowledged within '
                                   'this wall time', 0.1, 3600.0)
