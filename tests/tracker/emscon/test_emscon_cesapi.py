"""The public ``cesapi`` client (MuffinSpawn/Leica, from Leica's C API header) against our side.

Two levels: every packet layout we write is read back by cesapi's generated
classes (and cesapi's packets by our decoder), and a scripted cesapi session
runs over TCP against the simulator.
"""

from __future__ import annotations

import logging

import CESAPI.packet as cesapi_packet  # a test dependency (pyproject extra "test")
import numpy as np
from CESAPI.command import CommandSync
from CESAPI.connection import Connection
from emscon_kit import TARGET_MM

from drivers.tracker.emscon import protocol as pk


def test_our_server_packets_parse_in_cesapi_with_the_same_fields():
    values, std, meteo = (1.5, -2.25, 3.125), (0.01, 0.02, 0.03, 0.04), (21.0, 1001.0, 44.0)
    data = pk.encode_single_meas_result(values, std, meteo)
    res = cesapi_packet.SingleMeasResultT()
    res.unpack(data)
    assert len(data) == res.packetInfo.packetHeader.lPacketSize == 156
    assert res.packetInfo.packetHeader.type == cesapi_packet.ES_DT_SingleMeasResult
    assert (res.dVal1, res.dVal2, res.dVal3) == values
    assert (res.dStd1, res.dStd2, res.dStd3, res.dStdTotal) == std
    assert (res.dTemperature, res.dPressure, res.dHumidity) == meteo

    body = pk.system_status_body(pk.ProcessorStatus.INITIALIZED, 391234, (3, 6, 7))
    data = pk.encode_reply(pk.Command.GET_SYSTEM_STATUS, 0, body)
    st = cesapi_packet.GetSystemStatusRT()
    st.unpack(data)
    assert len(data) == st.packetInfo.packetHeader.lPacketSize == 56
    assert st.trackerProcessorStatus == cesapi_packet.ES_TPS_Initialized
    assert st.lTrackerSerialNumber == 391234
    assert st.esVersionNumber.iBuildNumber == 7

    data = pk.encode_reply(pk.Command.GET_UNITS, 0, pk.units_params())
    units = cesapi_packet.GetUnitsRT()
    units.unpack(data)
    assert units.unitsSettings.lenUnitType == cesapi_packet.ES_LU_Millimeter
    assert units.unitsSettings.pressUnitType == cesapi_packet.ES_PU_HPascal

    data = pk.encode_error(pk.Command.START_MEASUREMENT, 10004)
    err = cesapi_packet.ErrorResponseT()
    err.unpack(data)
    assert (err.command, err.status) == (cesapi_packet.ES_C_StartMeasurement, 10004)


def test_cesapi_result_packets_decode_in_ours():
    for cls in (cesapi_packet.SingleMeasResultT, cesapi_packet.SingleMeasResult2T):
        res = cls()
        res.dVal1, res.dVal2, res.dVal3 = 1000.5, -20.25, 3.0
        res.dStd1, res.dStd2, res.dStd3, res.dStdTotal = 0.001, 0.002, 0.003, 0.004
        res.dTemperature, res.dPressure, res.dHumidity = 20.5, 1010.0, 48.0
        got = pk.decode_server_packet(res.pack())
        assert got.values == (1000.5, -20.25, 3.0)
        assert got.std == (0.001, 0.002, 0.003, 0.004)
        assert got.meteo == (20.5, 1010.0, 48.0) and got.status == 0


def test_cesapi_command_packets_decode_in_ours():
    ct = cesapi_packet.SetUnitsCT()
    ct.unitsSettings.lenUnitType = cesapi_packet.ES_LU_Millimeter
    ct.unitsSettings.pressUnitType = cesapi_packet.ES_PU_HPascal
    command, params = pk.decode_client_packet(ct.pack())
    assert command == pk.Command.SET_UNITS
    assert pk.parse_units(params) == pk.parse_units(pk.units_params())

    ct = cesapi_packet.SetEnvironmentParamsCT()
    ct.environmentData.dTemperature, ct.environmentData.dPressure = 19.5, 990.0
    ct.environmentData.dHumidity = 35.0
    command, params = pk.decode_client_packet(ct.pack())
    assert pk.parse_env(params) == (19.5, 990.0, 35.0)

    ct = cesapi_packet.FindReflectorCT()
    ct.dAproxDistance = 2500.0
    assert ct.pack() == pk.encode_command(pk.Command.FIND_REFLECTOR, pk.double_param(2500.0))
    for name in ("StartMeasurementCT", "InitializeCT", "GetTrackerStatusCT", "GetUnitsCT"):
        data = getattr(cesapi_packet, name)().pack()
        assert pk.decode_client_packet(data)[1] == b""


def test_cesapi_scripted_session_against_the_simulator(exact_served):
    sim, server = exact_served
    sim.initialised = False
    logging.getLogger("CESAPI").setLevel(logging.WARNING)
    conn = Connection()
    conn.connect(host="127.0.0.1", port=server.port)
    try:
        cmd = CommandSync(conn)
        cmd.Initialize()
        assert sim.initialised

        units = cesapi_packet.SystemUnitsDataT()
        units.lenUnitType = cesapi_packet.ES_LU_Millimeter
        units.angUnitType = cesapi_packet.ES_AU_Radian
        units.tempUnitType = cesapi_packet.ES_TU_Celsius
        units.pressUnitType = cesapi_packet.ES_PU_HPascal
        units.humUnitType = cesapi_packet.ES_HU_RH
        cmd.SetUnits(units)
        got = cmd.GetUnits()
        assert got.unitsSettings.lenUnitType == cesapi_packet.ES_LU_Millimeter
        assert got.unitsSettings.angUnitType == cesapi_packet.ES_AU_Radian
        assert sim.units == pk.parse_units(pk.units_params())

        cmd.SetCoordinateSystemType(cesapi_packet.ES_CS_RHR)
        cmd.SetMeasurementMode(cesapi_packet.ES_MM_Stationary)
        assert cmd.GetCoordinateSystemType().coordSysType == cesapi_packet.ES_CS_RHR
        assert cmd.GetMeasurementMode().measMode == cesapi_packet.ES_MM_Stationary

        env = cesapi_packet.EnvironmentDataT()
        env.dTemperature, env.dPressure, env.dHumidity = 22.0, 995.0, 38.0
        cmd.SetEnvironmentParams(env)

        status = cmd.GetTrackerStatus()
        assert status.trackerStatus == cesapi_packet.ES_TS_Ready
        system = cmd.GetSystemStatus()
        assert system.trackerProcessorStatus == cesapi_packet.ES_TPS_Initialized
        assert system.lTrackerSerialNumber == sim.serial

        result = cmd.StartMeasurement()
        assert isinstance(result, cesapi_packet.SingleMeasResultT)
        assert result.packetInfo.status == cesapi_packet.ES_RS_AllOK
        np.testing.assert_array_equal([result.dVal1, result.dVal2, result.dVal3], TARGET_MM)
        assert (result.dTemperature, result.dPressure, result.dHumidity) == (22.0, 995.0, 38.0)

        sim.arm_fault("MEAS+1 beam_break count=100")  # stays broken until a search
        try:
            cmd.StartMeasurement()
            raise AssertionError("a broken beam measured")
        except Exception as exc:  # cesapi raises a bare Exception with the status
            assert "10004" in str(exc)
        cmd.FindReflector(float(np.linalg.norm(TARGET_MM)))
        result = cmd.StartMeasurement()
        assert result.packetInfo.status == cesapi_packet.ES_RS_AllOK
    finally:
        conn.disconnect()
