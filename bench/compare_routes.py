#!/usr/bin/env python3
"""Compares the paths of `dsmplan plan --routes ROUTES -o FOLDER/` runs route by route: solved
routes, length over the straight line between the ends (its lower bound), climb above the higher
waypoint, each arm's length over the first arm's on the routes both solved, and its energy over
the first arm's by a small multirotor's energy per kilogram, in metres of level flight: a metre of
path costs 1, a metre climbed 9.81 / (0.7 x 15) = 0.93 more (the climb's potential energy through a
propulsion efficiency of 0.7, against 150 W/kg at 10 m/s in level flight: Liu, Sengupta &
Kurzhanskiy, "A power consumption model for multi-rotor small unmanned aircraft systems", ICUAS
2017), a descent nothing back.
  bench/compare_routes.py ROUTES.csv NAME=FOLDER [NAME=FOLDER ...]"""
import csv, math, os, statistics, sys


def quantile(values, q):
    values = sorted(values)
    return values[min(len(values) - 1, int(q * len(values)))]


def read_path(folder, route):
    path = os.path.join(folder, route + ".csv")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        return [tuple(map(float, line.split(",")[:3])) for line in f if line[:1].isdigit()]


def length(path):
    return sum(math.dist(a, b) for a, b in zip(path, path[1:]))


def energy(path):
    return length(path) + 0.93 * sum(max(0.0, b[2] - a[2]) for a, b in zip(path, path[1:]))


def main():
    routes = {}
    with open(sys.argv[1]) as f:
        for row in csv.DictReader(f):
            routes.setdefault(row["route"], []).append((float(row["x"]), float(row["y"]), float(row["z"])))
    arms = [arg.split("=", 1) for arg in sys.argv[2:]]
    paths = {name: {r: read_path(folder, r) for r in routes} for name, folder in arms}
    first = arms[0][0]
    for name, _ in arms:
        solved = [r for r in routes if paths[name][r]]
        ratio = [length(paths[name][r]) / math.dist(routes[r][0], routes[r][-1]) for r in solved]
        climb = [max(p[2] for p in paths[name][r]) - max(p[2] for p in routes[r]) for r in solved]
        both = [r for r in solved if paths[first][r]]
        rel = [length(paths[name][r]) / length(paths[first][r]) for r in both]
        rel_energy = [energy(paths[name][r]) / energy(paths[first][r]) for r in both]
        print(f"{name}: solved {len(solved)}/{len(routes)}; length / straight line median {statistics.median(ratio):.3f} "
              f"p90 {quantile(ratio, .9):.3f} max {max(ratio):.3f}; climb p90 {quantile(climb, .9):.1f} m "
              f"max {max(climb):.1f} m; length / {first}'s median {statistics.median(rel):.3f} "
              f"p90 {quantile(rel, .9):.3f} max {max(rel):.3f}; energy / {first}'s median "
              f"{statistics.median(rel_energy):.3f} p90 {quantile(rel_energy, .9):.3f}")


if __name__ == "__main__":
    main()
