"""Live acquisition: the SCPI dialogue, the preamble, the curve decoders and the
saved "Save All" folder, against fakes and the simulated TDS 2012C (pyvisa-sim).

Independent truths: blocks made by ``pyvisa.util.to_ieee_block`` from known codes; the
programmer manual's formulas worked by hand; the virtual trainer's own quantised capture.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pyvisa_sim")  # fallback only: the test command installs the visa extra

from pyvisa.util import to_ieee_block

from motorid.errors import AcquisitionTimeoutError, ChannelOffError, InstrumentError, MotorIdError, OptionError
from motorid.io import read_tds_capture
from motorid.io.acquire import (
    AcquireSettings,
    Preamble,
    acquire_waveforms,
    decode_ascii_curve,
    decode_binary_curve,
    list_instruments,
    open_instrument,
    parse_field,
    parse_idn,
    resource_manager,
    save_acquisition,
    save_all_folder,
)
from motorid.io.acquire.curve import volts_per_div_that_fits
from motorid.io.sim import SIM_TEMPLATE, sim_resource

RNG = np.random.default_rng(17)


# --------------------------------------------------------------------------- decoders


def test_binary_block_decodes_every_signed_code():
    codes = np.arange(-128, 128, dtype=np.int8)  # every code, 0x0A (LF) and 0x80..0xFF included
    codes = np.concatenate([codes, RNG.integers(-128, 128, 2500 - codes.size).astype(np.int8)])
    block = bytes(to_ieee_block(codes, "b", True)) + b"\n"
    got = decode_binary_curve(block, n_points=2500)
    assert got.dtype.kind == "i" and np.array_equal(got, codes.astype(int))


def test_binary_block_errors():
    block = bytes(to_ieee_block(np.zeros(100, np.int8), "b", True))
    with pytest.raises(InstrumentError, match="preamble announced 2500"):
        decode_binary_curve(block, n_points=2500)
    with pytest.raises(InstrumentError, match="binary block"):
        decode_binary_curve(block[:50])  # cut short
    with pytest.raises(InstrumentError, match="binary block"):
        decode_binary_curve(b"1,2,3\n")


def test_ascii_curve_with_and_without_header():
    codes = RNG.integers(-128, 128, 2500)
    text = ",".join(map(str, codes))
    assert np.array_equal(decode_ascii_curve(text + "\n", n_points=2500), codes)
    assert np.array_equal(decode_ascii_curve(":CURVE " + text), codes)
    with pytest.raises(InstrumentError, match="garbled"):
        decode_ascii_curve("1,2,x3")
    with pytest.raises(InstrumentError, match="DATa:WIDth 1"):
        decode_ascii_curve("1,300")
    with pytest.raises(InstrumentError, match="no points"):
        decode_ascii_curve("")


@pytest.mark.parametrize("answer", ["8.0E-2", " 8.0E-2\n", ":WFMPRE:YMULT 8.0E-2", "YMU 8.0E-2", "WFMPRE:YMULT 0.08;"])
def test_preamble_field_parsed_by_keyword(answer):
    assert parse_field(answer, "WFMPre:YMUlt?") == pytest.approx(0.08, rel=0, abs=0)


def test_preamble_field_naming_another_field_or_no_number_is_refused():
    with pytest.raises(InstrumentError, match="YMUlt"):
        parse_field(":WFMPRE:XINCR 4.0E-3", "WFMPre:YMUlt?")
    with pytest.raises(InstrumentError, match="not a number"):
        parse_field("ERROR", "WFMPre:YMUlt?")


def test_preamble_formulas_worked_by_hand():
    # TDS2000 programmer manual: V = (code - YOFF)·YMULT + YZERO, t = XZERO + XINCR·(i - PT_OFF)
    p = Preamble(ymult=0.04, yzero=1.0, yoff=-25.0, xincr=0.002, xzero=0.5, pt_off=10.0, n_points=4)
    assert np.allclose(p.volts(np.array([0, 25, -25, 127])), [2.0, 3.0, 1.0, 7.08], rtol=0, atol=1e-12)
    assert np.allclose(p.times(4), [0.48, 0.482, 0.484, 0.486], rtol=0, atol=1e-12)
    assert p.screen_centre_v == pytest.approx(2.0)


def test_idn_fields():
    idn = parse_idn("TEKTRONIX,TDS 2012C,C010001,CF:91.1CT FV:v24.26\n")
    assert (idn.maker, idn.model, idn.serial, idn.firmware) == ("TEKTRONIX", "TDS 2012C", "C010001", "FV:v24.26")


def test_volts_per_div_advice_is_the_next_1_2_5_step_that_fits():
    # 4 divisions must hold the excursion: 10.16 V needs 2.54 V/div → 5; 3.9 V → 0.975 → 1
    assert volts_per_div_that_fits(10.16) == 5.0
    assert volts_per_div_that_fits(3.9) == 1.0
    assert volts_per_div_that_fits(4.1) == 2.0
    assert volts_per_div_that_fits(0.05) == pytest.approx(0.02)


# --------------------------------------------------------------------------- a binary fake


class FakeTds:
    """A TDS that speaks binary (what pyvisa-sim cannot): answers by keyword, records the dialogue.

    ``echo_headers``: answers carry their keyword (a firmware that ignores HEADer OFF);
    ``cut_at_lf``: ``read_raw`` stops after the first 0x0A byte, as a termination-character read does.
    """

    def __init__(self, codes: dict[int, np.ndarray], *, vpd=2.0, yoff=0.0, yzero=0.0, pt_off=400,
                 echo_headers=False, cut_at_lf=False):
        self.codes, self.vpd, self.yoff, self.yzero, self.pt_off = codes, vpd, yoff, yzero, pt_off
        self.echo, self.cut = echo_headers, cut_at_lf
        self.log: list[str] = []
        self.source = 1
        self.pending = b""

    def write(self, message):
        self.log.append(message)
        if message.startswith("DATa:SOUrce CH"):
            self.source = int(message[-1])
        if message == "CURVe?":
            self.pending = bytes(to_ieee_block(self.codes[self.source].astype(np.int8), "b", True)) + b"\n"

    def _answer(self, message):
        ymult = self.vpd / 25
        fields = {"WFMPre:YMUlt?": ymult, "WFMPre:YZEro?": self.yzero, "WFMPre:YOFf?": self.yoff,
                  "WFMPre:XINcr?": 0.004, "WFMPre:XZEro?": 0.0, "WFMPre:PT_Off?": self.pt_off,
                  "WFMPre:NR_Pt?": self.codes[self.source].size, "HORizontal:MAIn:SCAle?": 1.0,
                  f"CH{self.source}:SCAle?": self.vpd, "CH1:SCAle?": self.vpd, "CH2:SCAle?": self.vpd,
                  "CH1:PRObe?": 1.0, "CH2:PRObe?": 1.0}
        if message == "*IDN?":
            return "TEKTRONIX,TDS 2012C,C010001,CF:91.1CT FV:v24.26"
        if message.startswith("SELect:CH") or message == "ACQuire:STATE?":
            return "1" if message.startswith("SELect") else "0"
        value = f"{fields[message]:.6E}"
        return f":{message.rstrip('?').upper()} {value}" if self.echo else value

    def query(self, message):
        self.log.append(message)
        return self._answer(message) + "\n"

    def read_raw(self):
        data, self.pending = self.pending, b""
        if self.cut and b"\n" in data[:-1]:
            k = data.index(b"\n") + 1
            data, self.pending = data[:k], data[k:]
        return data

    def read_bytes(self, count):
        data, self.pending = self.pending[:count], self.pending[count:]
        return data


def _codes():
    c1 = np.where(np.arange(2500) >= 400, 74, 0)  # a 5.92 V step at 2 V/div
    c2 = np.clip(np.round(68 * (1 - np.exp(-np.maximum(np.arange(2500) - 400, 0) / 100))), -128, 127)
    c2[::97] = 10  # line feeds (0x0A) inside the binary block
    return {1: c1.astype(int), 2: c2.astype(int)}


@pytest.mark.parametrize("echo, cut", [(False, False), (True, False), (False, True)])
def test_binary_acquisition_follows_the_manual_and_scales_exactly(echo, cut):
    codes = _codes()
    fake = FakeTds(codes, echo_headers=echo, cut_at_lf=cut)
    acq = acquire_waveforms(fake, AcquireSettings(channels=(1, 2)), resource="FAKE")
    assert acq.warnings == ()
    for w in acq.waveforms:
        assert np.array_equal(w.codes, codes[w.channel])
        assert np.array_equal(w.volts, codes[w.channel] * (2.0 / 25))
        assert np.allclose(w.time_s, (np.arange(2500) - 400) * 0.004, rtol=0, atol=1e-12)
    # the manual's sequence, in order, for each channel
    seq = [m for m in fake.log if not m.startswith(("WFMPre", "CH", "SELect"))]
    assert seq[:3] == ["HEADer OFF", "*IDN?", "ACQuire:STATE STOP"]
    assert seq[4:10] == ["DATa:SOUrce CH1", "DATa:ENCdg RIBinary", "DATa:WIDth 1", "DATa:STARt 1",
                         "DATa:STOP 2500", "CURVe?"]
    asked = {m for m in fake.log if m.startswith("WFMPre")}
    assert asked == {f"WFMPre:{k}?" for k in ("YMUlt", "YZEro", "YOFf", "XINcr", "XZEro", "PT_Off", "NR_Pt")}


def test_single_arms_polls_and_times_out_without_waiting(monkeypatch):
    fake = FakeTds(_codes())
    states = iter(["1", "1", "0"])
    monkeypatch.setattr(fake, "_answer", lambda m, orig=fake._answer: next(states) if m == "ACQuire:STATE?"
                        else orig(m))
    acquire_waveforms(fake, AcquireSettings(single=True), sleep=lambda s: None)
    assert fake.log.count("ACQuire:STATE?") == 3
    assert fake.log.index("ACQuire:STOPAfter SEQuence") < fake.log.index("ACQuire:STATE RUN")
    # never triggers: the (fake) clock runs out; nothing really sleeps
    never = FakeTds(_codes())
    monkeypatch.setattr(never, "_answer", lambda m, orig=never._answer: "1" if m == "ACQuire:STATE?" else orig(m))
    ticks = iter(np.arange(0, 100, 0.5))
    with pytest.raises(AcquisitionTimeoutError, match="did not trigger within --timeout 2 s") as err:
        acquire_waveforms(never, AcquireSettings(single=True, timeout_s=2.0), clock=lambda: next(ticks),
                          sleep=lambda s: None)
    assert isinstance(err.value, TimeoutError) and "\n" not in str(err.value)
    assert never.log[-1] == "ACQuire:STATE STOP"


def test_clipped_channel_warns_with_the_scale_that_fits_and_reads_back_clipped(tmp_path):
    codes = _codes()
    codes[2] = np.where(np.arange(2500) >= 400, 127, 0)  # pinned at the top rail after the step
    acq = acquire_waveforms(FakeTds(codes), AcquireSettings())
    (warning,) = acq.warnings
    assert warning.startswith("CH2: 2100 of 2500 samples (84.0 %)") and "left the screen" in warning
    assert "above 10.16 V at 2 V/div" in warning and "set CH2 to 5 V/div or more" in warning
    folder = save_acquisition(acq, tmp_path / "ALL0003")
    cap = read_tds_capture(folder)
    assert any("clipped at the scope rails" in w for w in cap.warnings)  # the reader agrees


def test_offset_and_yzero_survive_the_files(tmp_path):
    # a trace moved down 1 division (YOFF = -25 codes) with YZERO 0.5 V: the files keep the volts
    codes = _codes()
    acq = acquire_waveforms(FakeTds(codes, yoff=-25.0, yzero=0.5), AcquireSettings())
    cap = read_tds_capture(save_acquisition(acq, tmp_path))
    assert np.allclose(cap.input_v, (codes[1] + 25) * 0.08 + 0.5, rtol=0, atol=1e-9)
    assert cap.input_info.yzero == 0.5 and cap.input_info.vertical_offset == pytest.approx(-2.0)


def test_settings_validate_themselves():
    for bad in ({"channels": (0,)}, {"channels": (1, 1)}, {"timeout_s": 0}, {"encoding": "hex"}):
        with pytest.raises(OptionError):
            AcquireSettings(**bad)


# --------------------------------------------------------------------------- the simulated TDS 2012C


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    from motorid.trainer.scope_sim import simulated_tds2012

    return simulated_tds2012(tmp_path_factory.mktemp("sim"), role="velocity", seed=0)


def test_simulated_scope_is_listed_with_its_idn(sim):
    rm = resource_manager(sim.visa_library)
    (found,) = list_instruments(rm)
    assert found.resource == sim.resource == "USB0::0x0699::0x03A4::VIRTUAL::0::INSTR"
    assert found.idn == "TEKTRONIX,TDS 2012C,VIRTUAL,CF:91.1CT FV:v24.26"


@pytest.mark.parametrize("encoding", ["ascii", "binary"])
def test_simulated_acquisition_gives_the_trainers_volts_exactly(sim, encoding, tmp_path):
    rm = resource_manager(sim.visa_library)
    with open_instrument(rm, sim.resource) as inst:
        acq = acquire_waveforms(inst, AcquireSettings(single=True, encoding=encoding))
    if encoding == "binary":  # pyvisa-sim sends text: the binary read falls back to ASCII and says so
        assert len(acq.warnings) == 2 and all("read as ASCII instead" in w for w in acq.warnings)
    else:
        assert acq.warnings == ()
    w1, w2 = acq.waveforms
    cap = sim.capture
    assert np.array_equal(w1.volts, cap.input_v) and np.array_equal(w2.volts, cap.output_v)
    assert np.array_equal(w1.time_s, cap.time_s)
    back = read_tds_capture(save_acquisition(acq, tmp_path))
    # the files hold decimal text: the same 8-bit levels, equal to the last bits of a double
    for got, want, lsb in ((back.output_v, cap.output_v, 2.0 / 25), (back.input_v, cap.input_v, 2.0 / 25)):
        assert np.array_equal(np.rint(got / lsb), np.rint(want / lsb))
        assert np.max(np.abs(got - want)) <= 1e-14
    assert np.max(np.abs(back.time_s - cap.time_s)) <= 1e-12
    assert back.scope.model == "TDS 2012C" and back.scope.trigger_index == cap.scope.trigger_index


def test_simulated_scope_that_never_triggers(tmp_path):
    from motorid.trainer.scope_sim import simulated_tds2012

    sim = simulated_tds2012(tmp_path, triggers=False)
    rm = resource_manager(sim.visa_library)
    with open_instrument(rm, sim.resource) as inst, pytest.raises(AcquisitionTimeoutError, match="--timeout"):
        acquire_waveforms(inst, AcquireSettings(single=True, timeout_s=0.2, poll_s=0.02))


def test_simulated_channel_off(tmp_path):
    from motorid.trainer.scope_sim import simulated_tds2012

    sim = simulated_tds2012(tmp_path, displayed=(1,))
    rm = resource_manager(sim.visa_library)
    with open_instrument(rm, sim.resource) as inst, pytest.raises(ChannelOffError, match="CH2 is switched off"):
        acquire_waveforms(inst, AcquireSettings(channels=(1, 2)))


def test_visa_timeout_of_a_mute_scope_is_one_line(tmp_path, sim):
    import yaml

    from pathlib import Path

    doc = yaml.safe_load(Path(sim.visa_library.rsplit("@", 1)[0]).read_text(encoding="utf-8"))
    for ch in doc["devices"]["TDS2012C"]["channels"].values():
        for d in ch["dialogues"]:
            if d["q"] == "CURVe?":
                d.pop("r")  # asked, never answered
    path = tmp_path / "mute.yaml"
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    rm = resource_manager(f"{path}@sim")
    with pytest.raises(AcquisitionTimeoutError, match=r"did not answer within 0\.3 s"), \
            open_instrument(rm, sim_resource(f"{path}@sim"), timeout_ms=300) as inst:
        acquire_waveforms(inst, AcquireSettings(encoding="ascii"))


def test_shipped_device_file_has_no_record_yet():
    rm = resource_manager(f"{SIM_TEMPLATE}@sim")
    with open_instrument(rm, sim_resource()) as inst, pytest.raises(InstrumentError, match="press RUN/STOP or SINGLE"):
        acquire_waveforms(inst, AcquireSettings(encoding="ascii"))


# --------------------------------------------------------------------------- the VISA session


def test_no_backend_is_one_line():
    with pytest.raises(InstrumentError, match="no VISA backend for --visa-library '@nosuchbackend'") as err:
        resource_manager("@nosuchbackend")
    assert isinstance(err.value, OSError) and "\n" not in str(err.value)


def test_unknown_resource_points_to_scope_list():
    from pyvisa.constants import StatusCode
    from pyvisa.errors import VisaIOError

    class NoSuchRm:  # what pyvisa-py raises for a resource that is not there (pyvisa-sim opens anything)
        def open_resource(self, name):
            raise VisaIOError(StatusCode.error_resource_not_found)

    with pytest.raises(InstrumentError, match="no such instrument: run 'motorid scope list'"), \
            open_instrument(NoSuchRm(), "USB0::0x1::0x2::X::0::INSTR"):
        pass


def test_permission_denied_names_the_udev_rule(monkeypatch):
    import sys

    class DeniedRm:
        def list_resources(self, query):
            return ("USB0::0x0699::0x0368::C065333::0::INSTR",)

        def open_resource(self, name):
            raise ValueError("[Errno 13] Access denied (insufficient permissions)")

    monkeypatch.setattr(sys, "platform", "linux")
    (found,) = list_instruments(DeniedRm())
    assert found.idn is None and "udev rule" in found.problem and 'ATTR{idVendor}=="0699"' in found.problem
    with pytest.raises(InstrumentError, match="no permission to open it"), \
            open_instrument(DeniedRm(), "USB0::0x0699::0x0368::C065333::0::INSTR"):
        pass


def test_save_folder_numbering(tmp_path):
    assert save_all_folder(tmp_path / "ALL0042") == (tmp_path / "ALL0042", 42)
    (tmp_path / "ALL0000").mkdir()
    (tmp_path / "ALL0001").mkdir()
    assert save_all_folder(tmp_path) == (tmp_path / "ALL0002", 2)
    (tmp_path / "f.txt").write_text("x")
    with pytest.raises(OptionError, match="is a file"):
        save_all_folder(tmp_path / "f.txt")


def test_existing_files_are_kept_without_force(tmp_path):
    acq = acquire_waveforms(FakeTds(_codes()), AcquireSettings())
    folder = save_acquisition(acq, tmp_path / "ALL0000")
    before = (folder / "F0000CH2.CSV").read_bytes()
    other = acquire_waveforms(FakeTds({1: _codes()[1], 2: _codes()[2] // 2}), AcquireSettings())
    with pytest.raises(MotorIdError, match="use force=True"):
        save_acquisition(other, folder)
    assert (folder / "F0000CH2.CSV").read_bytes() == before
    save_acquisition(other, folder, force=True)
    assert (folder / "F0000CH2.CSV").read_bytes() != before


def test_no_instrument_names_pyusb_when_pyvisa_py_cannot_reach_usb(monkeypatch):
    import importlib.util

    from motorid.io.acquire.visa import no_instrument_error

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "usb" else real(name, *a))
    assert "pip install pyusb" in str(no_instrument_error("@py"))
    assert "switch it on" in str(no_instrument_error("@ivi"))  # another backend: the cable and the access rule
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: object() if name == "usb" else real(name, *a))
    assert "switch it on" in str(no_instrument_error("@py"))
