"""``rig serve-sim``: the simulated VO2 device behind real Modbus and serial-line servers."""

from __future__ import annotations

import asyncio
import os
import signal
from pathlib import Path

import click

from drivers.clock import RealClock
from drivers.config import default_config, load_config
from drivers.sim import SimVO2
from drivers.sim.bench import SimBench, endpoints_from_config, parse_host_port
from drivers.sim.journal import open_journal_file

from ..output import print_json
from ..serve_addresses import check_free

DEFAULT_MODBUS = "127.0.0.1:5020"


@click.command("serve-sim")
@click.option("--modbus", "modbus_at", metavar="HOST:PORT",
              help=f"Serve Modbus TCP here (port 0: any free port; default {DEFAULT_MODBUS}, see below).")
@click.option("--modbus-rtu", "modbus_rtu_at", metavar="HOST:PORT", help="Serve Modbus RTU frames over TCP here.")
@click.option("--serial", "serial_at", metavar="socket://HOST:PORT|pty",
              help="Serve the line protocol on a TCP socket, or on a pseudo-terminal ('pty').")
@click.option("--config", "config_path", type=click.Path(dir_okay=False, path_type=Path),
              help="rig.toml: its [sim] physics, [modbus] register map and unit id, [serial] commands.")
@click.option("--seed", type=int, default=None, help="Seed of the PSD noise (overrides [sim] seed).")
@click.option("--allow-remote", is_flag=True, help="Allow listening on addresses other than loopback.")
@click.option("--journal", "journal_path", type=click.Path(dir_okay=False, path_type=Path),
              help="Append every set-point request (and start/stop) to this file as JSON lines, as it arrives.")
@click.option("--json", "as_json", is_flag=True, help="Once listening, print the endpoints as one JSON object.")
def serve_sim(modbus_at, modbus_rtu_at, serial_at, config_path, seed, allow_remote, journal_path, as_json):
    """Run the simulated device on loopback until Ctrl-C, in real time.

    With no endpoint option it listens where --config's clients connect
    ([modbus] host/port, a socket:// [serial] url), else on Modbus TCP
    127.0.0.1:5020.
    """
    cfg = load_config(config_path) if config_path else default_config()
    params = cfg.sim
    if seed is not None:
        from dataclasses import replace

        params = replace(params, seed=seed)
    if not (modbus_at or modbus_rtu_at or serial_at):
        derived = endpoints_from_config(cfg.modbus, cfg.serial) if config_path else {}
        modbus_at = derived.get("modbus")
        modbus_rtu_at = derived.get("modbus_rtu")
        serial_at = derived.get("serial")
        if not derived:
            modbus_at = DEFAULT_MODBUS
    modbus = parse_host_port(modbus_at, "--modbus", allow_remote) if modbus_at else None
    modbus_rtu = parse_host_port(modbus_rtu_at, "--modbus-rtu", allow_remote) if modbus_rtu_at else None
    serial_tcp = None
    if serial_at and serial_at != "pty":
        if not serial_at.startswith("socket://"):
            raise click.BadParameter("give socket://HOST:PORT or pty", param_hint="--serial")
        serial_tcp = parse_host_port(serial_at.removeprefix("socket://"), "--serial", allow_remote)
    check_free({"--modbus": modbus, "--modbus-rtu": modbus_rtu, "--serial": serial_tcp})
    device = SimVO2(params, RealClock())
    bench = SimBench(device, cfg.modbus, cfg.serial)
    sink = None
    if journal_path is not None:
        try:
            sink = open_journal_file(journal_path)
        except OSError as exc:
            raise click.BadParameter(f"cannot write {journal_path}: {exc.strerror}", param_hint="--journal") from None
        bench.journal.sink = sink
    try:
        asyncio.run(_serve(bench, modbus, modbus_rtu, serial_at, as_json))
        bench.journal.event("stop", heater_V=device.applied_voltage)
    finally:
        if sink is not None:
            sink.close()
    requests = bench.journal.setpoints
    click.echo(
        f"serve-sim: stopped; {len(requests)} set-point request(s) received, "
        f"{sum(not r.accepted for r in requests)} refused; heater at {device.applied_voltage:g} V",
        err=True,
    )


async def _serve(bench: SimBench, modbus, modbus_rtu, serial_at, as_json: bool) -> None:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    try:
        if modbus:
            await bench.start_modbus(*modbus)
        if modbus_rtu:
            await bench.start_modbus(*modbus_rtu, rtu=True)
        if serial_at:
            await bench.start_serial(serial_at)
        bench.journal.event("start", pid=os.getpid(), endpoints=dict(bench.endpoints))
        if as_json:
            print_json(dict(bench.endpoints))
        else:
            for name, where in bench.endpoints.items():
                click.echo(f"{name:10s} {where}")
            click.echo("serving the simulated VO2 device; Ctrl-C to stop", err=True)
        await stop.wait()
    finally:
        await bench.stop_all()
