#!/usr/bin/env python3
"""Summarise a tools/gpu-bench.sh folder: prints Markdown tables (the README's GPU section)
and writes ladder.csv. Usage: gpu_bench_summary.py DIR. Standard library only."""
import csv
import json
import statistics
import sys
from pathlib import Path


def load(path):
    try:
        return json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return None


def objects(text):
    """Every JSON value in `text` (the ladder's records are pretty-printed one after another)."""
    dec, i, out = json.JSONDecoder(), 0, []
    while True:
        while i < len(text) and text[i].isspace():
            i += 1
        if i >= len(text):
            return out
        value, i = dec.raw_decode(text, i)
        out.append(value)


def ms(x):
    return "–" if x is None else (f"{x:.3f}" if x < 10 else f"{x:.1f}")


def main(d):
    d = Path(d)
    cal = load(d / "calibration.json") or {}
    print(f"# tiltfield on {cal.get('device', '?')}\n")
    print(f"Driver {cal.get('driver', '?')}, Vulkan {cal.get('api_version', '?')}.\n")
    if cal:
        print("## `--strategy auto` calibration (5×5 views of 512², GPU medians)\n")
        print("| strategy | ms | chosen |\n|---|---|---|")
        for name, t in sorted(cal.get("medians_ms", {}).items(), key=lambda kv: kv[1]):
            print(f"| {name} | {ms(t)} | {'yes' if name == cal.get('chosen') else ''} |")
        print()

    ladder_path = d / "ladder.jsonl"
    rows = objects(ladder_path.read_text()) if ladder_path.exists() else []
    ladder_path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    table, pixels = {}, {}
    with open(d / "ladder.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["strategy", "strategy_used", "antialias", "compute_shape", "views",
                    "gpu_refocus_median_ms", "frames"])
        for r in rows:
            rr = r["render"]
            t = rr["timings_ms"]["gpu_refocus_median"]
            w.writerow([r["strategy"], rr.get("strategy"), r["antialias"],
                        r.get("compute_shape", ""), rr.get("views_used"), t,
                        rr["timings_ms"]["frames"]])
            if "compute_shape" in r:
                pixels[r["compute_shape"]] = (t, rr)
            else:
                table[(r["strategy"], r["antialias"])] = (t, rr)
    if table:
        used = {s: rr.get("strategy") for (s, _), (_, rr) in table.items()}
        first = next(iter(table.values()))[1]
        side = "×".join(str(x) for x in first["light_field"]["size"])
        print(f"## Refocus GPU medians, {first.get('views_used')} views of {side} "
              "(`render --repeat`)\n")
        print("| strategy | plain | anti-aliased (default) | × plain | defocused views | × plain |")
        print("|---|---|---|---|---|---|")
        for s in ["auto", "fragment", "compute", "batched:16"]:
            p = table.get((s, "off"), (None,))[0]
            a = table.get((s, "on"), (None,))[0]
            f = table.get((s, "defocus"), (None,))[0]
            ratio = lambda x: "–" if x is None or not p else f"{x / p:.1f}×"
            label = f"auto ({used.get(s)})" if s == "auto" else s
            print(f"| {label} | {ms(p)} | {ms(a)} | {ratio(a)} | {ms(f)} | {ratio(f)} |")
        plain = [table[(s, "off")][0] for s in ["fragment", "compute", "batched:16"]
                 if (s, "off") in table]
        if plain and ("auto", "off") in table:
            print(f"\nauto / fastest plain: {table[('auto', 'off')][0] / min(plain):.2f}×\n")
    if pixels:
        print("## Compute shapes of the plain sum\n")
        print("| pixels per invocation | views per iteration | workgroup | storage | ms | "
              "view samples/s |\n|---|---|---|---|---|---|")
        for shape, (t, rr) in sorted(pixels.items(), key=lambda kv: kv[1][0]):
            sps = rr.get("view_samples_per_second")
            cells = " | ".join(shape.split())
            print(f"| {cells} | {ms(t)} | {'–' if not sps else f'{sps / 1e9:.0f} G'} |")
        print()

    bench = load(d / "bench" / "bench.json")
    if bench:
        lfr = bench["light_field"]
        side = "×".join(str(x) for x in lfr["view_size"])
        print(f"## bench ({lfr['views_used']} views of {side}): variants by GPU median\n")
        print("| variant | ms | G samples/s | texture roof | GB/s | bandwidth roof | within bound |")
        print("|---|---|---|---|---|---|---|")
        for v in sorted(bench["variants"], key=lambda v: v["gpu_ms_median"]):
            roof = v.get("texture_roof_fraction")
            bw = v.get("bandwidth_roof_fraction")
            print(f"| {v['name']}{' (default)' if v.get('default') else ''} | "
                  f"{ms(v['gpu_ms_median'])} | {v['samples_per_s'] / 1e9:.1f} | "
                  f"{'–' if roof is None else f'{100 * roof:.0f} %'} | {v.get('gbps', 0):.0f} | "
                  f"{'–' if bw is None else f'{100 * bw:.0f} %'} | {v['within_bound']} |")
        print(f"\nPeak figures: {bench['device']['peak'].get('source')}.\n")

    depth = [load(d / f"depth-{i}.json") for i in (1, 2, 3)]
    depth = [x["estimate"]["timings"] for x in depth if x]
    if depth:
        total = statistics.median(t["total_ms"] for t in depth)
        gpu = statistics.median(t["gpu_ms"] for t in depth)
        print(f"## Depth of the same light field\n\nmedian of {len(depth)} runs: "
              f"{total:.0f} ms in all, {gpu:.1f} ms of GPU work.\n")

    for name, label in [("antialias-set.json", "default"),
                        ("antialias-set-defocus.json", "defocused views")]:
        a = load(d / name)
        if not a:
            continue
        r = a["rows"]
        mean = lambda key, part: statistics.mean(x[key][part] for x in r)
        print(f"## antialias-set ({label}, {len(r)} cases, {a.get('size')} px)\n")
        print(f"mean PSNR against the lens: given depth {mean('given', 'overall'):.1f} dB, "
              f"estimated {mean('estimated', 'overall'):.1f} dB, plain {mean('plain', 'overall'):.1f}"
              f" dB; mean cost {statistics.mean(x['cost_ratio'] for x in r):.1f}× the plain sum.\n")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
