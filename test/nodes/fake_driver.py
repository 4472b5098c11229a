"""A deliberately broken driver for the check-drivers tests: publishes the measured topics of
the sequencer and the servo at 1 kHz with the faults named on the command line.

Faults: ``slow_force`` (load_cell_1 at 10 Hz), ``kn_force`` (load_cell_2 in kN),
``frozen_encoder`` (encoder stamps never advance), ``gauge_pressure`` (valve_1 in gauge Pa),
``wrong_type_encoder`` (std_msgs/Float64 on the encoder topic). Runs until SIGINT.
"""

from __future__ import annotations

import sys
import time

import rclpy
from geometry_msgs.msg import WrenchStamped
from sensor_msgs.msg import FluidPressure, JointState
from std_msgs.msg import Float64

from pam_bench.models.constants import ATMOSPHERE_PA
from pam_bench.runtime.base import DRIVER
from pam_bench.runtime.messages import time_of


def main() -> None:
    faults = set(sys.argv[1:])
    rclpy.init()
    node = rclpy.create_node('fake_driver')
    cell = [node.create_publisher(WrenchStamped, f'load_cell_{i}/force', DRIVER) for i in (1, 2)]
    enc = node.create_publisher(Float64 if 'wrong_type_encoder' in faults else JointState,
                                'encoder/joint_state', DRIVER)
    pres = node.create_publisher(FluidPressure, 'valve_1/pressure', DRIVER)
    for t in ('valve_1/command', 'valve_2/command', 'loading_servo/command'):
        node.create_subscription(Float64, t + '_unused', lambda m: None, 1)
    k = 0
    t0 = time.time_ns()
    try:
        while rclpy.ok():
            now = time.time_ns()
            for i, pub in enumerate(cell):
                if i == 0 and 'slow_force' in faults and k % 100:
                    continue
                m = WrenchStamped()
                m.header.stamp = time_of(now)
                m.header.frame_id = 'base_link' if 'wrong_frame' in faults else \
                    f'load_cell_{i + 1}'
                f = 300.0 + 0.061 * (k % 7)
                m.wrench.force.x = f / 1000.0 if i == 1 and 'kn_force' in faults else f
                pub.publish(m)
            if 'wrong_type_encoder' in faults:
                enc.publish(Float64(data=0.1))
            else:
                js = JointState(name=['pulley'], position=[0.1])
                js.header.stamp = time_of(t0 if 'frozen_encoder' in faults else now)
                enc.publish(js)
            p = FluidPressure(fluid_pressure=(0.0 if 'gauge_pressure' in faults
                                              else ATMOSPHERE_PA) + 3.0 * (k % 5))
            p.header.stamp = time_of(now)
            p.header.frame_id = 'valve_1'
            pres.publish(p)
            k += 1
            time.sleep(max(0.0, t0 * 1e-9 + k * 1e-3 - time.time()))
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
