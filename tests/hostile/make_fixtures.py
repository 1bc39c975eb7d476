#!/usr/bin/env python3
"""Writes the hostile-input fixtures of tests/hostile/ (run once; the outputs are committed).

Usage: tests/hostile/make_fixtures.py DSMPLAN_BINARY

Each file is small and wrong in one known way; catalogue.json says how dsmplan must refuse it.
LAS fixtures start from the first 300 points of the real Delft AHN3 sample, so everything but
the one lie is a real file. Rasters are VRTs over tiny raw float32 files (GDAL reads them, and a
VRT can declare any size for free); meshes and the roadmap are made by dsmplan itself from a
40 m x 40 m synthetic block with one building, then damaged where a case needs it.
"""
import json
import math
import os
import shutil
import struct
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
DELFT = os.path.join(REPO, "data", "delft-ahn3", "ahn3_cropped_2.las")


def out(name, data, mode="wb"):
    with open(os.path.join(HERE, name), mode) as f:
        f.write(data)


# ---- LAS ------------------------------------------------------------------------------------

def delft_las(points=300):
    """A LAS 1.2 file (227-byte header, no VLRs, format 1) of the first `points` Delft points."""
    with open(DELFT, "rb") as f:
        head = bytearray(f.read(227))
        offset = struct.unpack_from("<I", head, 96)[0]
        length = struct.unpack_from("<H", head, 105)[0]
        f.seek(offset)
        body = f.read(points * length)
    assert head[24:26] == b"\x01\x02" and offset == 227 and struct.unpack_from("<I", head, 100)[0] == 0
    struct.pack_into("<I", head, 107, points)
    struct.pack_into("<5I", head, 111, points, 0, 0, 0, 0)  # points by return
    return head, body


def las_fixtures():
    head, body = delft_las()
    out("good_300.las", bytes(head) + body)  # a sound base, used by the roadmap/mesh fixtures too

    out("las_truncated_header.las", bytes(head[:100]))

    h = bytearray(head)
    struct.pack_into("<I", h, 107, 1_000_000)  # 1e6 points claimed, 300 present
    out("las_count_past_end.las", bytes(h) + body)

    # LAS 1.4: the 64-bit count at byte 247 says 10^12 points (legacy count 0, as 1.4 allows).
    h14 = bytearray(375)
    h14[:227] = head
    h14[25] = 4
    struct.pack_into("<H", h14, 94, 375)
    struct.pack_into("<I", h14, 96, 375)
    struct.pack_into("<I", h14, 107, 0)
    struct.pack_into("<Q", h14, 247, 10**12)
    out("las_count_1e12.las", bytes(h14) + body)
    # Only the header of a file that is all there: the test extends it (sparse, no disk used) to the
    # 1.1 TB that 4*10^10 points of 28 bytes take, whose 1 TB in memory no test machine has.
    struct.pack_into("<Q", h14, 247, 4 * 10**10)
    out("las_huge_header.las", bytes(h14))

    # Two points 2e9 m apart (x scale 1, offset -1e9; X 0 and 2e9): a grid of 2e9 cells a row.
    h = bytearray(head)
    length = struct.unpack_from("<H", head, 105)[0]
    far = bytearray(body[:2 * length])
    struct.pack_into("<I", h, 107, 2)
    struct.pack_into("<d", h, 131, 1.0)
    struct.pack_into("<d", h, 155, -1e9)
    struct.pack_into("<d", h, 179, 1e9)
    struct.pack_into("<d", h, 187, -1e9)
    struct.pack_into("<i", far, 0, 0)
    struct.pack_into("<i", far, length, 2_000_000_000)
    out("las_far_apart.las", bytes(h) + bytes(far))

    h = bytearray(head)
    struct.pack_into("<I", h, 96, 1_000_000_000)  # point data "starts" 1 GB in
    out("las_offset_past_end.las", bytes(h) + body)

    h = bytearray(head)
    struct.pack_into("<H", h, 94, 100)  # header size smaller than the 1.2 header itself
    out("las_header_size_wrong.las", bytes(h) + body)

    h = bytearray(head)
    h[0:4] = b"LASX"
    out("las_bad_signature.las", bytes(h) + body)

    h = bytearray(head)
    struct.pack_into("<H", h, 105, 10)  # format 1 records are 28 bytes
    out("las_record_too_short.las", bytes(h) + body)

    h = bytearray(head)
    struct.pack_into("<d", h, 131, 0.0)  # x scale 0
    out("las_zero_scale.las", bytes(h) + body)

    h = bytearray(head)
    struct.pack_into("<d", h, 147, float("nan"))  # z scale NaN: every height NaN
    out("las_nan_scale.las", bytes(h) + body)

    h = bytearray(head)
    h[104] |= 0x80  # LAZ flag
    out("las_laz_flag.las", bytes(h) + body)

    h = bytearray(head)
    struct.pack_into("<I", h, 100, 5)  # 5 VLRs claimed, none between header and points
    out("las_vlr_overrun.las", bytes(h) + body)

    h = bytearray(head)
    h[24], h[25] = 2, 0
    out("las_version_2.las", bytes(h) + body)

    out("las_cut_in_points.las", bytes(head) + body[: len(body) // 2 + 13])  # cut mid-record


# ---- XYZ ------------------------------------------------------------------------------------

def xyz_fixtures():
    rows = ["85000.10 446000.20 1.50", "85000.60 446000.30 1.70", "85001.10 446000.80 2.10"]
    out("xyz_nan_height.xyz", ("\n".join(rows[:2] + ["85001.10 446000.80 nan"]) + "\n").encode())
    out("xyz_inf_height.xyz", ("\n".join(rows[:1] + ["85000.60 446000.30 inf"] + rows[2:]) + "\n").encode())
    out("xyz_malformed.xyz", ("\n".join(rows[:2] + ["85001.10;446000.80;one point one"]) + "\n").encode())
    out("xyz_header_only.xyz", b"X Y Z\n# nothing measured\n")


# ---- rasters --------------------------------------------------------------------------------

X0, Y0, W, H = 356300.0, 5699790.0, 40, 40
FEET_X0, FEET_Y0 = 11800000.0, 7000000.0  # EPSG:2283, US survey feet


def raw(values):
    return struct.pack("<%df" % len(values), *values)


def vrt(name, width, height, gt, srs="EPSG:25832", source=None, nodata=None, unit=None, offset=None):
    band_open = '  <VRTRasterBand dataType="Float32" band="1"%s>\n' % (
        ' subClass="VRTRawRasterBand"' if source else "")
    text = '<VRTDataset rasterXSize="%d" rasterYSize="%d">\n' % (width, height)
    if srs:
        text += "  <SRS>%s</SRS>\n" % srs
    text += "  <GeoTransform>%s</GeoTransform>\n" % ", ".join(repr(float(v)) for v in gt)
    text += band_open
    if nodata is not None:
        text += "    <NoDataValue>%s</NoDataValue>\n" % nodata
    if unit is not None:
        text += "    <UnitType>%s</UnitType>\n" % unit
    if offset is not None:
        text += "    <Offset>%s</Offset>\n" % offset
    if source:
        text += ('    <SourceFilename relativetoVRT="1">%s</SourceFilename>\n'
                 "    <ImageOffset>0</ImageOffset><PixelOffset>4</PixelOffset>"
                 "<LineOffset>%d</LineOffset><ByteOrder>LSB</ByteOrder>\n" % (source, 4 * width))
    text += "  </VRTRasterBand>\n</VRTDataset>\n"
    out(name, text.encode())


def block(building=70.0):
    """40 x 40 cells of 1 m: ground at 50 m, a 10 m x 10 m building (cells 15-24) of `building` m."""
    return [building if 15 <= c < 25 and 15 <= r < 25 else 50.0 for r in range(H) for c in range(W)]


def raster_fixtures():
    north_up = (X0, 1, 0, Y0, 0, -1)
    out("block.bin", raw(block()))
    vrt("block.vrt", W, H, north_up, source="block.bin")
    out("block_taller.bin", raw(block(75.0)))
    vrt("block_taller.vrt", W, H, north_up, source="block_taller.bin")
    # Terrain for plan --dtm: the block's cells in another CRS, and in the right CRS 10 km away.
    vrt("dtm_other_crs.vrt", W, H, north_up, source="block.bin", srs="EPSG:32632")
    vrt("dtm_elsewhere.vrt", W, H, (X0 + 10000, 1, 0, Y0, 0, -1), source="block.bin")
    # The western half of the block only (20 of its 40 columns): a --dsm that covers part of the mesh.
    out("dsm_west_half.vrt", open(os.path.join(HERE, "block.vrt")).read().replace(
        'rasterXSize="40"', 'rasterXSize="20"').encode())

    small = [50.0 + i for i in range(16)]
    nan_cells = list(small)
    nan_cells[5] = float("nan")
    out("raster_nan.bin", raw(nan_cells))
    vrt("raster_nan.vrt", 4, 4, north_up, source="raster_nan.bin")

    inf_cells = list(small)
    inf_cells[10] = float("inf")
    out("raster_inf.bin", raw(inf_cells))
    vrt("raster_inf.vrt", 4, 4, north_up, source="raster_inf.bin")

    out("raster_all_nodata.bin", raw([-9999.0] * 16))
    vrt("raster_all_nodata.vrt", 4, 4, north_up, source="raster_all_nodata.bin", nodata=-9999)

    out("raster_4x4.bin", raw(small))
    vrt("raster_rotated.vrt", 4, 4, (X0, 0.866, 0.5, Y0, 0.5, -0.866), source="raster_4x4.bin")
    vrt("raster_zero_cell.vrt", 4, 4, (X0, 0, 0, Y0, 0, -1), source="raster_4x4.bin")
    vrt("raster_no_crs.vrt", 4, 4, north_up, srs=None, source="raster_4x4.bin")
    vrt("raster_geographic.vrt", 4, 4, (6.9, 0.00001, 0, 51.4, 0, -0.00001), srs="EPSG:4326",
        source="raster_4x4.bin")
    # Units other than the metre. NAD83 / Virginia North (ftUS): x 11,800,000 ftUS is 96.6 km east
    # of the projection's 78.5 W, y 7,000,000 ftUS 133.6 km north of its 37.67 N: about 77.39 W,
    # 38.87 N, UTM zone 18. The block's heights in feet (band unit type), and NAD83 / UTM zone 18N
    # + NAVD88 height (ftUS) near the same place.
    vrt("raster_feet.vrt", 4, 4, (FEET_X0, 3, 0, FEET_Y0, 0, -3), srs="EPSG:2283", source="raster_4x4.bin")
    vrt("raster_feet_vertical.vrt", W, H, north_up, source="block.bin", unit="ft")
    vrt("raster_navd88_ft.vrt", 4, 4, (543300.0, 1, 0, 4306000.0, 0, -1), srs="EPSG:26918+6360",
        source="raster_4x4.bin")
    # 10^6 x 10^6 cells with no source: GDAL would serve zeros, 4 TB of them.
    vrt("raster_huge.vrt", 1_000_000, 1_000_000, north_up)
    vrt("raster_one_row.vrt", 4, 1, north_up, source="raster_4x4.bin")
    # Valid cells on one line only: one row with holes, and a diagonal (no triangle can be made).
    line = [-9999.0] * 144
    for c in range(12):
        if c % 3 != 1:
            line[5 * 12 + c] = 50.0 + c
    out("raster_line.bin", raw(line))
    vrt("raster_line.vrt", 12, 12, north_up, source="raster_line.bin", nodata=-9999)
    diagonal = [-9999.0] * 144
    for k in range(12):
        diagonal[k * 12 + k] = 50.0
    out("raster_diagonal.bin", raw(diagonal))
    vrt("raster_diagonal.vrt", 12, 12, north_up, source="raster_diagonal.bin", nodata=-9999)
    # An origin at 1e16 (1 m cells round together there), and undeclared sentinels: -FLT_MAX, 1e15.
    vrt("raster_far_origin.vrt", 4, 4, (1e16, 1, 0, 1e16, 0, -1), source="raster_4x4.bin")
    sentinel = list(small)
    sentinel[6] = -3.4028234663852886e38
    out("raster_flt_max.bin", raw(sentinel))
    vrt("raster_flt_max.vrt", 4, 4, north_up, source="raster_flt_max.bin")
    towering = list(small)
    towering[9] = 1e15
    out("raster_1e15.bin", raw(towering))
    vrt("raster_1e15.vrt", 4, 4, north_up, source="raster_1e15.bin")
    out("raster_text.tif", b"Heights of Delft, see attached spreadsheet.\n")
    out("raster_missing_source.vrt",
        open(os.path.join(HERE, "raster_nan.vrt")).read().replace("raster_nan.bin", "gone.bin").encode())


# ---- meshes, waypoints, roadmaps ------------------------------------------------------------

def roadmap_edges_past_end(roadmap):
    """Node 0's edge list ends 1000 listings past the last one, behind a valid checksum (FNV-1a
    of all bytes before it): read out of bounds until fuzz/fuzz_roadmap found it."""
    data = bytearray(roadmap[:-8])
    nodes, listings = struct.unpack_from("<QQ", data, 60)
    struct.pack_into("<I", data, 76 + nodes * 24 + 4, listings + 1000)  # start[1]: 24-byte nodes first
    h = 14695981039346656037
    for b in data:
        h = ((h ^ b) * 1099511628211) & 0xFFFFFFFFFFFFFFFF
    return bytes(data) + struct.pack("<Q", h)


def run(dsmplan, *args):
    subprocess.run([dsmplan, *args], check=True, stdout=subprocess.DEVNULL)


def plan_fixtures(dsmplan):
    tmp = os.path.join(HERE, "_tmp")
    os.makedirs(tmp, exist_ok=True)
    try:
        # dsmplan writes the one-cell GeoTIFF and a small real GeoTIFF (to be cut) itself.
        with open(os.path.join(tmp, "one.xyz"), "w") as f:
            f.write("356300.5 5699789.5 51.0\n")
        run(dsmplan, "grid", os.path.join(tmp, "one.xyz"), "-o", os.path.join(HERE, "raster_one_cell.tif"),
            "--res", "1", "--crs", "EPSG:25832", "-q")
        run(dsmplan, "grid", os.path.join(HERE, "good_300.las"), "-o", os.path.join(tmp, "delft.tif"),
            "--res", "0.5", "--crs", "EPSG:28992", "-q")
        tif = open(os.path.join(tmp, "delft.tif"), "rb").read()
        out("raster_truncated.tif", tif[: len(tif) // 2])

        run(dsmplan, "simplify", os.path.join(HERE, "block.vrt"), "-o", os.path.join(HERE, "block.ply"),
            "--method", "variant1", "-q")
        run(dsmplan, "simplify", os.path.join(HERE, "block_taller.vrt"), "-o", os.path.join(tmp, "taller.ply"),
            "--method", "variant1", "-q")
        run(dsmplan, "plan", os.path.join(tmp, "taller.ply"), "--waypoints", os.path.join(HERE, "wp_good.csv"),
            "-o", os.path.join(tmp, "path.csv"), "--spacing", "6", "--max-agl", "10",
            "--roadmap", os.path.join(HERE, "roadmap_other_mesh.roadmap"), "-q")
        roadmap = open(os.path.join(HERE, "roadmap_other_mesh.roadmap"), "rb").read()
        out("roadmap_truncated.roadmap", roadmap[: len(roadmap) // 3])
        damaged = bytearray(roadmap)
        damaged[len(damaged) // 2] ^= 0xFF
        out("roadmap_damaged.roadmap", bytes(damaged))
        out("roadmap_edges_past_end.roadmap", roadmap_edges_past_end(roadmap))

        ply = open(os.path.join(HERE, "block.ply"), "rb").read()
        out("mesh_truncated.ply", ply[: len(ply) * 2 // 3])
        end = ply.index(b"end_header\n")
        header = ply[:end].decode()
        vertices = int(header.split("element vertex ")[1].split()[0])
        out("mesh_huge_count.ply", header.replace("element vertex %d" % vertices,
                                                   "element vertex 1000000000000").encode() + ply[end:])
    finally:
        shutil.rmtree(tmp)

    out("mesh_bad_index.obj", b"# a triangle naming a vertex that is not there\n"
        b"v 356300 5699750 50\nv 356310 5699750 50\nv 356300 5699760 50\nf 1 2 9\n")
    out("mesh_nan_vertex.off", b"OFF\n3 1 0\n356300 5699750 50\n356310 5699750 nan\n356300 5699760 50\n3 0 1 2\n")


def unit_fixtures(dsmplan):
    """Meshes in feet, as their header comments say (only a WKT: the units are read from it), and
    with heights in feet. dsmplan describes the CRS (info); it will not mesh it."""
    info = subprocess.run([dsmplan, "info", os.path.join(HERE, "raster_feet.vrt"), "--json"], check=True,
                          stdout=subprocess.PIPE).stdout
    wkt = json.loads(info)["crs"]["wkt"]
    out("mesh_feet.obj", ("# crs_name NAD83 / Virginia North (ftUS)\n# crs_wkt %s\n# vertical unknown\n"
                          "v %.1f %.1f 300\nv %.1f %.1f 300\nv %.1f %.1f 330\nf 1 2 3\n" % (
                              wkt, FEET_X0, FEET_Y0 - 120, FEET_X0 + 120, FEET_Y0 - 120, FEET_X0, FEET_Y0)).encode())
    ply = open(os.path.join(HERE, "block.ply"), "rb").read()
    end = ply.index(b"end_header\n")
    header = ply[:end].decode()
    vertical = [line for line in header.split("\n") if line.startswith("comment vertical ")][0]
    out("mesh_feet_vertical.ply", header.replace(vertical, "comment vertical unknown (ft)").encode() + ply[end:])
    # The same mesh with its CRS lost: no unit to measure a safety distance in (issue 49).
    bare = "\n".join(line for line in header.split("\n") if not line.startswith(("comment crs_", "comment vertical ")))
    out("mesh_no_crs.ply", bare.encode() + ply[end:])


def waypoint_fixtures():
    head = "x,y,z\n"
    a, b = "356303,5699787,56\n", "356337,5699753,56\n"
    out("wp_good.csv", (head + a + b).encode())
    out("wp_inside_building.csv", (head + a + "356320,5699770,60\n" + b).encode())  # roof at 70 m
    out("wp_under_ground.csv", (head + a + "356305,5699760,40\n" + b).encode())  # ground at 50 m
    out("wp_outside_extent.csv", (head + a + "356900,5699770,60\n" + b).encode())
    out("wp_too_high.csv", (head + a + "356310,5699760,400\n" + b).encode())  # far above --max-agl
    # Routes: a second route whose id is 300 characters (it names a file: refused before any is written).
    long_id = "r" * 300
    out("routes_long_id.csv", ("route,x,y,z\nfirst," + a + "first," + b + long_id + "," + a + long_id + "," + b).encode())
    # Coordinates nested 100,000 arrays deep: the message once dumped them, recursing off the stack.
    out("wp_deep.geojson", (b'{"type": "FeatureCollection", "features": [{"type": "Feature", "geometry": '
                            b'{"type": "Point", "coordinates": ' + b"[" * 100000 + b"]" * 100000 + b"}}]}"))
    out("wp_near_wall.csv", (head + a + "356313.8,5699770,60\n" + b).encode())  # 1.2 m west of the wall
    # Several bad waypoints in one file: every one is named in one run.
    out("wp_several_bad.csv", (head + a + "356320,5699770,60\n356305,5699760,40\n" + b).encode())
    out("wp_several_near_columns.csv", (head + a + "356313.8,5699770,60\n356320,5699770,60\n" + b).encode())
    out("wp_malformed.csv", (head + a + "356320;5699770;60\n" + b).encode())
    out("wp_nan.csv", (head + a + "356320,5699770,nan\n" + b).encode())
    out("wp_one_point.csv", (head + a).encode())
    out("wp_truncated.geojson", b'{"type": "FeatureCollection", "features": [{"type": "Feature", "geometry": '
        b'{"type": "Point", "coordinates": [6.9, 51.4')
    # Valid JSON, but the height is beyond a double (nlohmann throws out_of_range: found by fuzzing).
    out("wp_number_overflow.geojson", b'{"type": "Point", "coordinates": [6.9, 51.4, 1e400]}\n')
    out("wp_polygon.geojson", b'{"type": "Feature", "properties": {}, "geometry": {"type": "Polygon", '
        b'"coordinates": [[[6.9, 51.4, 60], [6.91, 51.4, 60], [6.91, 51.41, 60], [6.9, 51.4, 60]]]}}\n')
    out("wp_no_height.geojson", b'{"type": "LineString", "coordinates": [[6.9, 51.4], [6.91, 51.41]]}\n')
    out("wp_swapped.geojson", b'{"type": "LineString", "coordinates": [[356303, 5699787, 56], '
        b'[356337, 5699753, 56]]}\n')
    out("plain.txt", b"an ordinary file: outputs under it cannot be created\n")


# ---- data that disagree --------------------------------------------------------------------

def disagreement_fixtures():
    """Data that would be flown wrong: a terrain 10 m above its DSM (a vertical datum mismatch), a
    DSM in Web Mercator (lengths 1.59 times the ground's at 51 N), cameras in degrees, in an
    Earth-centred frame and in Web Mercator."""
    north_up = (X0, 1, 0, Y0, 0, -1)
    vrt("dtm_plus10.vrt", W, H, north_up, source="block.bin", offset=10)
    # 770 km east, 6621 km north in EPSG:3857: 6.92 E, 51.0 N (UTM zone 32).
    vrt("raster_web_mercator.vrt", W, H, (770000.0, 1, 0, 6621000.0, 0, -1), srs="EPSG:3857", source="block.bin")

    def cameras(name, crs, centres):
        nadir = [[1, 0, 0], [0, -1, 0], [0, 0, -1]]
        out(name, json.dumps({"crs": crs, "cameras": [
            {"image": "view%d.tif" % i, "width": 640, "height": 480, "fx": 800, "fy": 800, "cx": 320, "cy": 240,
             "rotation": nadir, "center": c} for i, c in enumerate(centres)]}, indent=1).encode())

    cameras("cameras_geographic.json", "EPSG:4326", [[6.9, 51.4, 300], [6.9005, 51.4, 300]])
    cameras("cameras_geocentric.json", "EPSG:4978", [[3980000, 482000, 4960000], [3980030, 482000, 4960000]])
    cameras("cameras_web_mercator.json", "EPSG:3857", [[770000, 6621000, 300], [770050, 6621000, 300]])
    # Cameras whose images are plain.txt (beside it): `--stats` on it would replace an input.
    text = json.loads(open(os.path.join(HERE, "cameras_geographic.json")).read())
    text["crs"] = "EPSG:25832"
    for i, camera in enumerate(text["cameras"]):
        camera["image"], camera["center"] = "plain.txt", [356300 + 50 * i, 5699770, 300]
    out("cameras_plain_images.json", json.dumps(text, indent=1).encode())
    # Cameras 1e12 m from the origin, and points there: rasters no reader of dsmplan would open.
    for i, camera in enumerate(text["cameras"]):
        camera["center"] = [1e12 + 50 * i, 1e12, 300]
    out("cameras_far.json", json.dumps(text, indent=1).encode())
    # Two cameras 5 cm apart, 250 m over the heights: no depth to measure.
    text["height_range"] = [40, 80]
    for i, camera in enumerate(text["cameras"]):
        camera["center"] = [356300 + 0.05 * i, 5699770, 300]
    out("cameras_5cm.json", json.dumps(text, indent=1).encode())
    # Valid JSON syntax, a number beyond a double: nlohmann throws out_of_range (found by fuzz_cameras).
    out("cameras_number_overflow.json", b'{"crs": "EPSG:25832", "cameras": [640e3003, 1]}\n')
    out("xyz_far.xyz", b"1e12 1e12 5.0\n1000000000010 1e12 6.0\n1e12 1000000000010 7.0\n")


# ---- LAZ ------------------------------------------------------------------------------------

def laz_fixtures():
    """Copies of laspy's LAZ test files (data/laz-conformance/) wrong in one known way."""
    conformance = os.path.join(REPO, "data", "laz-conformance")
    with open(os.path.join(conformance, "simple.laz"), "rb") as f:
        simple = f.read()
    with open(os.path.join(conformance, "1_4_w_evlr.laz"), "rb") as f:
        layered = f.read()
    assert struct.unpack_from("<I", simple, 96)[0] == 333 and struct.unpack_from("<I", layered, 96)[0] == 2399
    vlr = 227 + 54  # simple.laz: the "laszip encoded" VLR is its only one
    assert simple[227 + 2:227 + 16] == b"laszip encoded"

    out("laz_truncated.laz", simple[:len(simple) * 6 // 10])  # the chunk table is gone
    h = bytearray(simple)
    struct.pack_into("<H", h, vlr, 9)  # compressor 9
    out("laz_bad_compressor.laz", bytes(h))
    h = bytearray(simple)
    struct.pack_into("<H", h, vlr + 34 + 6, 42)  # item 2: type 42 instead of GPSTIME11
    out("laz_unknown_item.laz", bytes(h))
    h = bytearray(layered)
    struct.pack_into("<I", h, 2399 + 8 + 30, 777)  # the layered chunk's own count: 777, table 1000
    out("laz_chunk_count_lies.laz", bytes(h))


def zone_fixtures():
    """No-fly zones over the block (GeoJSON and ED-269, longitude and latitude by GDAL's OSR)."""
    from osgeo import osr
    utm, wgs84 = osr.SpatialReference(), osr.SpatialReference()
    utm.ImportFromEPSG(25832)
    wgs84.ImportFromEPSG(4326)
    wgs84.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    to_wgs84 = osr.CoordinateTransformation(utm, wgs84)

    def square(x, y, h):
        ring = [to_wgs84.TransformPoint(x + dx, y + dy)[:2] for dx, dy in ((-h, -h), (h, -h), (h, h), (-h, h), (-h, -h))]
        return [[round(lon, 9), round(lat, 9)] for lon, lat in ring]

    def geojson(name, ring, extra=None):
        properties = {"name": name, **(extra or {})}
        return json.dumps({"type": "FeatureCollection", "features": [
            {"type": "Feature", "properties": properties, "geometry": {"type": "Polygon", "coordinates": [ring]}}]})

    out("zones_on_waypoint.geojson", geojson("school yard", square(356303, 5699787, 2)).encode())  # wp_good's first
    out("zones_on_home.geojson", geojson("helipad", square(356305, 5699755, 2)).encode())
    ed269 = {"features": [{"identifier": "ZONE-1", "name": "yards", "restriction": "PROHIBITED",
                           "geometry": [{"uomDimensions": "YD", "lowerLimit": 0, "lowerVerticalReference": "AGL",
                                         "upperLimit": 100, "upperVerticalReference": "AGL",
                                         "horizontalProjection": {"type": "Polygon",
                                                                  "coordinates": [square(356320, 5699770, 5)]}}]}]}
    out("zones_bad_uom.json", json.dumps(ed269).encode())


def glb_fixtures():
    """GLBs for dsmplan view --no-fly, which needs the CRS of the GLB's asset.extras."""
    def glb(document, cut=None):
        text = json.dumps(document).encode()
        text += b" " * (-len(text) % 4)
        chunk = struct.pack("<I4s", len(text), b"JSON") + text
        data = struct.pack("<4sII", b"glTF", 2, 12 + len(chunk)) + chunk
        return data if cut is None else data[:cut]

    with_crs = {"asset": {"version": "2.0", "extras": {"crs": {"name": "ETRS89 / UTM zone 32N", "epsg": 25832}}}}
    out("glb_crs_only.glb", glb(with_crs))
    out("glb_no_crs.glb", glb({"asset": {"version": "2.0"}}))
    out("glb_json_cut.glb", glb(with_crs, cut=40))


# ---- COLMAP models and their georeference ----------------------------------------------------

def colmap_fixtures():
    """COLMAP text models (`stereo --colmap`) wrong in one known way, in folders colmap_*/, and the
    files that put a model in the CRS (--centres, --gcps, --transform) wrong in one way each. The
    good model: three nadir PINHOLE cameras 30 m apart over the block (COLMAP's world-to-camera
    quaternion (0, 1, 0, 0): x east, y south, z down; the model frame is the CRS shifted)."""
    def model(folder, cameras, images):
        os.makedirs(os.path.join(HERE, folder), exist_ok=True)
        out(os.path.join(folder, "cameras.txt"), cameras.encode())
        out(os.path.join(folder, "images.txt"), images.encode())

    good_cameras = "# CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]\n1 PINHOLE 640 480 800 800 320 240\n"
    centres = [(0, 0, 300), (30, 0, 300), (15, 25, 300)]

    def image_lines(qw=0.0, qx=1.0, qy=0.0, qz=0.0, centres=centres):
        # x_cam = R X + t with R = diag(1, -1, -1): t = -R C
        return "".join("%d %r %r %r %r %r %r %r 1 view%d.tif\n\n" % (i + 1, qw, qx, qy, qz, -x, y, z, i)
                       for i, (x, y, z) in enumerate(centres))

    model("colmap_good", good_cameras, image_lines())
    model("colmap_fisheye", "1 OPENCV_FISHEYE 640 480 800 800 320 240 0.1 0 0 0\n", image_lines())
    model("colmap_zero_quaternion", good_cameras, image_lines(qx=0.0))
    model("colmap_number_overflow", "1 PINHOLE 640 480 8e999 800 320 240\n", image_lines())
    model("colmap_on_a_line", good_cameras, image_lines(centres=[(0, 0, 300), (30, 0, 300), (60, 0, 300)]))
    os.makedirs(os.path.join(HERE, "colmap_binary"), exist_ok=True)
    out(os.path.join("colmap_binary", "cameras.bin"), struct.pack("<Q", 0))
    # Centres: the CRS is the model shifted to the block (356300, 5699770); one centre NaN; three
    # centres on a line.
    out("colmap_centres_nan.csv", b"image,x,y,z\nview0.tif,356300,5699770,300\nview1.tif,nan,5699770,300\n")
    out("colmap_centres_line.csv", b"image,x,y,z\nview0.tif,356300,5699770,300\nview1.tif,356330,5699770,300\n"
        b"view2.tif,356360,5699770,300\n")
    # Ground control points: one seen in a single image; a header without v; a point whose two
    # rows give other heights.
    out("colmap_gcps_one_view.csv", b"point,x,y,z,image,u,v\nA,356310,5699760,60,view0.tif,330,230\n")
    out("colmap_gcps_no_v.csv", b"point,x,y,z,image,u\nA,356310,5699760,60,view0.tif,330\n")
    out("colmap_gcps_moved.csv", b"point,x,y,z,image,u,v\nA,356310,5699760,60,view0.tif,330,230\n"
        b"A,356310,5699760,61,view1.tif,250,230\n")
    # The good model's images as plain text (--centres exif reads their EXIF).
    os.makedirs(os.path.join(HERE, "colmap_plain_images"), exist_ok=True)
    for i in range(3):
        out(os.path.join("colmap_plain_images", "view%d.tif" % i), b"not an image\n")
    # A transform that mirrors (determinant < 0): no rotation.
    out("colmap_transform_mirror.txt", b"1 0 0 356300\n0 1 0 5699770\n0 0 -1 0\n0 0 0 1\n")


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    las_fixtures()
    laz_fixtures()
    xyz_fixtures()
    raster_fixtures()
    disagreement_fixtures()
    waypoint_fixtures()
    zone_fixtures()
    glb_fixtures()
    colmap_fixtures()
    plan_fixtures(os.path.abspath(sys.argv[1]))
    unit_fixtures(os.path.abspath(sys.argv[1]))


if __name__ == "__main__":
    main()
