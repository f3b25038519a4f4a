"""Bit-timed models of the CAN and RS485 downlinks (issue #39) and of I2C at the same level.

`can` (frames to the bit, stuffing, CRC-15, arbitration, fault confinement), `rs485` (characters,
Modbus RTU silences, driver turnaround), `cores` (the phase-1 C framing of firmware/downlink through
ctypes: the frames' data and the RS485 timing come from it), `cycle` (the SensoRHex motor and sensor
cycles on each downlink), `plant` (the hip motor for the control experiment). sim/README.md,
"Downlinks".
"""
