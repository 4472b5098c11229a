"""Field buses: register maps and Modbus I/O, the CiA 402 drive on CANopen, a loopback CAN hub."""

__all__ = ['can_hub', 'canopen_drive', 'cia402', 'errors', 'modbus_io', 'register_map']
