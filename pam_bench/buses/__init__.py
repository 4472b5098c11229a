"""Field buses: register maps, the CiA 402 drive, a CAN hub on loopback, the bench behind them."""

__all__ = ['can_hub', 'canopen_drive', 'cia402', 'emulated', 'errors', 'modbus_io',
           'register_map', 'serve']
