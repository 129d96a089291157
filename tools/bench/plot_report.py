"""Plots and report.html of a `tether bench` run, from its bench.json (matplotlib).

usage: plot_report.py BENCH_JSON OUT_DIR

Writes into OUT_DIR: latency_cdf.png (per device, one line per point), success_vs_ber.png,
p99_vs_rate.png, bytes_per_op.png, cpu_per_op.png and report.html, which shows the parameters, a verdict
per criterion, the tables and the plots (the PNG files beside it). Exit status 3 when matplotlib is
missing (Debian: python3-matplotlib), 2 for a malformed bench.json.
"""
import html
import json
import math
import os
import sys

try:
    import matplotlib

    matplotlib.use("Agg")  # no display: files only
    import matplotlib.pyplot as plt
except ImportError:
    sys.stderr.write("plot_report.py: matplotlib is missing (Debian: apt install python3-matplotlib)\n")
    sys.exit(3)

PLOTS = [
    ("latency_cdf.png", "Latency CDF per device"),
    ("success_vs_ber.png", "Success % vs bit error rate"),
    ("p99_vs_rate.png", "p99 latency vs rate"),
    ("bytes_per_op.png", "Wire bytes per operation"),
    ("cpu_per_op.png", "Device CPU per operation"),
]
WIDTH_IN, HEIGHT_IN, DPI = 8.0, 4.5, 100  # every plot is 800 x 450 pixels


def rate_label(rate):
    return "max" if rate is None else f"{rate:g}/s"


def point_label(point):
    return f"BER {point['bit_error_rate']:g}, {rate_label(point['rate_hz'])}"


def reference_point(points, device):
    """The device's cleanest point: the lowest BER, then the first rate swept."""
    own = [p for p in points if p["device"] == device and p["operations"] > 0]
    if not own:
        return None
    lowest = min(p["bit_error_rate"] for p in own)
    return next(p for p in own if p["bit_error_rate"] == lowest)


def new_figure():
    return plt.subplots(figsize=(WIDTH_IN, HEIGHT_IN), dpi=DPI)


def save(figure, out_dir, name):
    figure.tight_layout()
    figure.savefig(os.path.join(out_dir, name), dpi=DPI)
    plt.close(figure)


def plot_cdf(report, out_dir):
    devices = [d["device"] for d in report["devices"]]
    columns = min(3, max(1, len(devices)))
    rows = max(1, math.ceil(len(devices) / columns))
    figure, axes = plt.subplots(rows, columns, figsize=(WIDTH_IN, HEIGHT_IN), dpi=DPI, squeeze=False)
    for index, device in enumerate(devices):
        axis = axes[index // columns][index % columns]
        for point in report["points"]:
            if point["device"] != device or not point["latency_cdf"]:
                continue
            xs = [x for x, _ in point["latency_cdf"]]
            ys = [y for _, y in point["latency_cdf"]]
            axis.step(xs, ys, where="post", label=point_label(point))
        axis.set_title(device, fontsize=9)
        axis.set_xlabel("latency (ms)", fontsize=8)
        axis.set_ylim(0, 1.02)
        axis.tick_params(labelsize=7)
        axis.grid(True, alpha=0.3)
        if index == 0:
            axis.set_ylabel("share of operations", fontsize=8)
            axis.legend(fontsize=6)
    for index in range(len(devices), rows * columns):
        axes[index // columns][index % columns].axis("off")
    save(figure, out_dir, "latency_cdf.png")


def plot_success_vs_ber(report, out_dir):
    figure, axis = new_figure()
    bers = sorted(report["parameters"]["bit_error_rates"])
    positive = [b for b in bers if b > 0]
    for device in report["devices"]:
        name = device["device"]
        for rate in report["parameters"]["rates_hz"]:
            rate_value = None if rate == "max" else rate
            series = [(p["bit_error_rate"], p["success_percent"]) for p in report["points"]
                      if p["device"] == name and p["rate_hz"] == rate_value]
            series.sort()
            if series:
                label = name if len(report["parameters"]["rates_hz"]) == 1 else f"{name} ({rate_label(rate_value)})"
                axis.plot([x for x, _ in series], [y for _, y in series], marker="o", label=label)
    if positive:
        axis.set_xscale("symlog", linthresh=min(positive))
    axis.set_xlabel("bit error rate (both directions)")
    axis.set_ylabel("success %")
    axis.set_ylim(-2, 102)
    axis.grid(True, alpha=0.3)
    axis.legend(fontsize=7)
    save(figure, out_dir, "success_vs_ber.png")


def plot_p99_vs_rate(report, out_dir):
    figure, axis = new_figure()
    lowest = min(report["parameters"]["bit_error_rates"])
    for device in report["devices"]:
        name = device["device"]
        # Each point sits at the rate it achieved: a device slower than the rate asked falls behind it, and
        # the closed loop (max) reaches its saturation rate.
        series = sorted((p["throughput_hz"], p["latency_ms"]["p99"], rate_label(p["rate_hz"]))
                        for p in report["points"] if p["device"] == name and p["bit_error_rate"] == lowest)
        if series:
            axis.plot([x for x, _, _ in series], [y for _, y, _ in series], marker="o", label=name)
            for x, y, asked in series:
                axis.annotate(asked, (x, y), fontsize=6, textcoords="offset points", xytext=(3, 3))
    axis.set_xlabel(f"operations per second achieved per device (BER {lowest:g}; labels: the rate asked)")
    axis.set_ylabel("p99 latency (ms)")
    axis.grid(True, alpha=0.3)
    axis.legend(fontsize=7)
    save(figure, out_dir, "p99_vs_rate.png")


def plot_bytes(report, out_dir):
    figure, axis = new_figure()
    names, to_device, from_device = [], [], []
    for device in report["devices"]:
        point = reference_point(report["points"], device["device"])
        if point:
            names.append(device["device"])
            to_device.append(point["bytes_per_op_to_device"])
            from_device.append(point["bytes_per_op_from_device"])
    axis.bar(names, to_device, label="host to device")
    axis.bar(names, from_device, bottom=to_device, label="device to host")
    axis.set_ylabel("wire bytes per operation")
    axis.set_title("at each device's lowest BER and first rate", fontsize=9)
    axis.grid(True, axis="y", alpha=0.3)
    axis.legend(fontsize=7)
    save(figure, out_dir, "bytes_per_op.png")


def plot_cpu(report, out_dir):
    figure, axis = new_figure()
    names, own, background = [], [], []
    for device in report["devices"]:
        point = reference_point(report["points"], device["device"])
        if point and point["cpu_cycles_per_op"] is not None:
            names.append(device["device"])
            above = point["cpu_cycles_per_op_above_idle"]
            above = point["cpu_cycles_per_op"] if above is None else max(0.0, above)
            own.append(above)
            background.append(point["cpu_cycles_per_op"] - above)
    if names:
        axis.bar(names, own, color="tab:green", label="the operation (above idle)")
        axis.bar(names, background, bottom=own, color="tab:gray", alpha=0.5,
                 label="background while idle (ticks, pings, state streams)")
        axis.legend(fontsize=7)
    else:
        axis.text(0.5, 0.5, "no virtual boards: the device CPU is not measurable", ha="center", transform=axis.transAxes)
    axis.set_ylabel("AVR cycles executed per operation")
    axis.set_title("all of the device's boards, sleep left out; lowest BER, first rate", fontsize=9)
    axis.grid(True, axis="y", alpha=0.3)
    save(figure, out_dir, "cpu_per_op.png")


def verdicts(report):
    """(criterion, winner, why) per criterion, from the measured points."""
    points = report["points"]
    devices = report["devices"]
    confirmed = {d["device"] for d in devices if d["confirmed"]}
    result = []
    references = {d["device"]: reference_point(points, d["device"]) for d in devices}
    references = {name: p for name, p in references.items() if p}

    candidates = {n: p for n, p in references.items() if n in confirmed}
    if candidates:
        best = min(candidates, key=lambda n: candidates[n]["latency_ms"]["p50"])
        result.append(("Lowest latency", best, f"p50 {candidates[best]['latency_ms']['p50']:.1f} ms, p99 "
                       f"{candidates[best]['latency_ms']['p99']:.1f} ms at {point_label(candidates[best])} "
                       "(confirmed operations only)"))
    if references:
        total = {n: p["bytes_per_op_to_device"] + p["bytes_per_op_from_device"] for n, p in references.items()}
        best = min(total, key=total.get)
        result.append(("Fewest bytes", best, f"{total[best]:.1f} wire bytes per operation at "
                       f"{point_label(references[best])}"))
    noisiest = max(report["parameters"]["bit_error_rates"])
    at_noise = {}
    for p in points:
        if p["bit_error_rate"] == noisiest and p["operations"] > 0 and p["device"] in confirmed:
            ok, ops, wrong = at_noise.get(p["device"], (0, 0, 0))
            at_noise[p["device"]] = (ok + p["successes"], ops + p["operations"], wrong + p["wrong"])
    if at_noise:
        best = max(at_noise, key=lambda n: (at_noise[n][0] / at_noise[n][1], -at_noise[n][2]))
        ok, ops, wrong = at_noise[best]
        result.append(("Most robust under noise", best, f"{100.0 * ok / ops:.1f} % success, {wrong} wrong answers "
                       f"at BER {noisiest:g} (confirmed operations only)"))
    cpu = {n: p["cpu_cycles_per_op_above_idle"] if p["cpu_cycles_per_op_above_idle"] is not None
           else p["cpu_cycles_per_op"] for n, p in references.items() if p["cpu_cycles_per_op"] is not None}
    if cpu:
        best = min(cpu, key=cpu.get)
        result.append(("Lowest device CPU", best, f"{cpu[best]:.0f} AVR cycles per operation above idle at "
                       f"{point_label(references[best])}"))
    return result


def table(headers, rows):
    out = ["<table>", "<tr>" + "".join(f"<th>{html.escape(str(h))}</th>" for h in headers) + "</tr>"]
    for row in rows:
        out.append("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in row) + "</tr>")
    out.append("</table>")
    return "\n".join(out)


def number(value, decimals=1):
    return "-" if value is None else f"{value:.{decimals}f}"


def witness(point):
    """The exactly-once figures of a point (the firmware's execution witness), '-' without one."""
    figures = point.get("exactly_once")
    if not figures:
        return "-"
    return (f"{figures['confirmed']}/{figures['commands']} / {figures['executed']} / {figures['executed_twice']} / "
            f"{figures['executed_but_failed']} / {figures['confirmed_not_executed']}")


def write_html(report, out_dir):
    parameters = report["parameters"]
    parameter_rows = [
        ("rover", report["rover"]),
        ("Tether version", report["tether_version"]),
        ("bit error rates", ", ".join(f"{b:g}" for b in parameters["bit_error_rates"])),
        ("rates (operations/s per device)", ", ".join(str(r) for r in parameters["rates_hz"])),
        ("per device and point", f"{parameters['duration_s']} s" if parameters["duration_s"] is not None
         else f"{parameters['iterations']} operations"),
        ("devices", "one at a time" if parameters["isolated"] else "all at once"),
        ("resets", "a power cycle halfway through every point" if parameters["reset"] else "none"),
        ("workload", parameters.get("workload", "servo")),
        ("payload", parameters.get("payload", "demo")),
        ("saturation", "a ramp per device and BER" if parameters.get("saturation_ramp") else "from the swept rates"),
        ("skipped", "; ".join(f"{d['device']}: {d['why']}" for d in report.get("skipped", [])) or "none"),
        ("seed", parameters["seed"]),
        ("wall time", f"{report['wall_seconds']:.1f} s"),
    ]
    point_rows = []
    for p in report["points"]:
        drops = p["drops"]
        point_rows.append((p["device"], f"{p['bit_error_rate']:g}", rate_label(p["rate_hz"]), p["operations"],
                           number(p["success_percent"]), p["wrong"], number(p["latency_ms"]["p50"]),
                           number(p["latency_ms"]["p90"]), number(p["latency_ms"]["p99"]),
                           number(p["latency_ms"]["max"]),
                           f"{p['bytes_per_op_to_device']:.1f} + {p['bytes_per_op_from_device']:.1f}",
                           number(None if p["utilisation_to_device"] is None else 100 * p["utilisation_to_device"]),
                           p["retries"],
                           f"{drops['stale']}/{drops['crc']}/{drops['framing']}/{drops['oversize']}",
                           number(p["cpu_cycles_per_op"], 0), number(p["cpu_cycles_per_op_above_idle"], 0),
                           number(p["recovery_ms"], 0), witness(p)))
    device_rows = []
    for d in report["devices"]:
        firmware = "; ".join(f"{os.path.basename(f['path'])} {f['flash_bytes']} B flash, sha256 {f['sha256'][:12]}"
                             for f in d["firmware"]) or "-"
        saturation = "; ".join(f"BER {s['bit_error_rate']:g}: {number(s['sustained_hz'])} op/s"
                               + (f", breaks down at {number(s['breaks_down_hz'])}" if s["breaks_down_hz"] else "")
                               + (f" ({s['breaks_down_because']})" if s.get("breaks_down_because") else "")
                               for s in d["saturation"]) or "-"
        device_rows.append((d["device"], d["codec"], d["operation"], firmware, saturation))
    verdict_rows = verdicts(report)
    images = "\n".join(f'<figure><img src="{name}" alt="{html.escape(title)}" width="800" height="450">'
                       f"<figcaption>{html.escape(title)}</figcaption></figure>" for name, title in PLOTS)
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>tether bench: {html.escape(report['rover'])}</title>
<style>
body {{ font-family: sans-serif; margin: 1.5em; }}
table {{ border-collapse: collapse; margin-bottom: 1.5em; font-size: 0.85em; }}
th, td {{ border: 1px solid #bbb; padding: 0.2em 0.5em; text-align: right; }}
th {{ background: #eee; }}
td:first-child, th:first-child {{ text-align: left; }}
figure {{ display: inline-block; margin: 0.5em; }}
</style></head><body>
<h1>tether bench: {html.escape(report['rover'])}</h1>
<h2>Parameters</h2>
{table(("parameter", "value"), parameter_rows)}
<h2>Verdict</h2>
{table(("criterion", "device", "measured"), verdict_rows)}
<h2>Devices</h2>
{table(("device", "codec", "operation", "firmware", "sustained with >= 99 % success"), device_rows)}
<h2>Points</h2>
{table(("device", "BER", "rate", "ops", "success %", "wrong", "p50 ms", "p90 ms", "p99 ms", "max ms",
        "bytes/op to + from", "link use to %", "retries", "drops stale/crc/framing/oversize", "cycles/op",
        "cycles/op above idle", "recovery ms",
        "commands confirmed / executed / twice / executed but failed / confirmed not executed"), point_rows)}
<h2>Plots</h2>
{images}
</body></html>
"""
    with open(os.path.join(out_dir, "report.html"), "w", encoding="utf-8") as file:
        file.write(page)


def main(argv):
    if len(argv) != 3:
        sys.stderr.write("usage: plot_report.py BENCH_JSON OUT_DIR\n")
        return 2
    try:
        with open(argv[1], encoding="utf-8") as file:
            report = json.load(file)
        for key in ("rover", "parameters", "devices", "points"):
            if key not in report:
                raise KeyError(key)
    except (OSError, ValueError, KeyError) as error:
        sys.stderr.write(f"plot_report.py: {argv[1]}: not a bench.json ({error})\n")
        return 2
    out_dir = argv[2]
    plot_cdf(report, out_dir)
    plot_success_vs_ber(report, out_dir)
    plot_p99_vs_rate(report, out_dir)
    plot_bytes(report, out_dir)
    plot_cpu(report, out_dir)
    write_html(report, out_dir)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
