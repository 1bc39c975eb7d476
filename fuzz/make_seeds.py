#!/usr/bin/env python3
"""Writes the seed corpora of fuzz/corpus/<target>/ from the real data and the hostile fixtures.

Usage: fuzz/make_seeds.py   (from anywhere). It adds the seeds to the folders; the committed
corpora are these seeds merged (libFuzzer -merge=1, file names become hashes) with what fuzzing
found: MERGE=1 scripts/fuzz.sh SECONDS.

LAS seeds are a few dozen real points of data/delft-ahn3 under four valid headers (LAS 1.2
format 1 as delivered, 1.2 with a VLR, 1.3, 1.4 format 6); XYZ seeds are those points as text;
meshes are small PLY (ascii/binary), OBJ and OFF files; waypoints come from
data/nrw-dom1/sample_waypoints.csv; plus every tests/hostile/ fixture of the same kind. Index seeds
are `dsmplan plan --index` files of the NRW sample meshed at 50 m and 25 m (the dsmplan binary of
build/ writes them; skipped when there is none).
fuzz_pipeline reads its bytes through FuzzedDataProvider (grid size, georeference and options
from the end, cell heights from the front), so its seeds are byte strings of a few sizes from a
fixed random sequence: each decodes to some grid and options, and the fuzzer takes it from there.
"""
import glob
import os
import random
import shutil
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
CORPUS = os.path.join(HERE, "corpus")
HOSTILE = os.path.join(REPO, "tests", "hostile")


def put(target, name, data):
    os.makedirs(os.path.join(CORPUS, target), exist_ok=True)
    with open(os.path.join(CORPUS, target, name), "wb" if isinstance(data, bytes) else "w") as f:
        f.write(data)


def hostile(target, pattern):
    os.makedirs(os.path.join(CORPUS, target), exist_ok=True)
    for path in sorted(glob.glob(os.path.join(HOSTILE, pattern))):
        shutil.copy(path, os.path.join(CORPUS, target, os.path.basename(path)))


def delft(name, points):
    with open(os.path.join(REPO, "data", "delft-ahn3", name), "rb") as f:
        head = bytearray(f.read(227))
        offset = struct.unpack_from("<I", head, 96)[0]
        length = struct.unpack_from("<H", head, 105)[0]
        f.seek(offset)
        body = f.read(points * length)
    assert head[24:26] == b"\x01\x02" and head[104] == 1 and length == 28
    head = head[:227]
    struct.pack_into("<I", head, 96, 227)   # offset to point data: no VLRs kept
    struct.pack_into("<I", head, 100, 0)    # number of VLRs
    struct.pack_into("<I", head, 107, points)
    struct.pack_into("<5I", head, 111, points, 0, 0, 0, 0)
    return head, body


def las_seeds():
    for i, name in enumerate(["ahn3_cropped_1.las", "ahn3_cropped_2.las"]):
        head, body = delft(name, 40)
        put("las", f"delft{i + 1}_las12_f1.las", bytes(head + body))
    head, body = delft("ahn3_cropped_2.las", 24)
    # 1.2 with one VLR (a 54-byte header and 16 bytes of payload).
    vlr = b"\0\0" + b"dsmplan".ljust(16, b"\0") + struct.pack("<HH", 1, 16) + b"fuzz seed".ljust(32, b"\0")
    vlr += b"0123456789abcdef"
    h = bytearray(head)
    struct.pack_into("<I", h, 96, 227 + len(vlr))
    struct.pack_into("<I", h, 100, 1)
    put("las", "delft_las12_vlr.las", bytes(h) + vlr + body)
    # 1.3: 235-byte header (start of waveform data record = 0).
    h = bytearray(head)
    h[25] = 3
    struct.pack_into("<H", h, 94, 235)
    struct.pack_into("<I", h, 96, 235)
    put("las", "delft_las13_f1.las", bytes(h) + bytes(8) + body)
    # 1.4 format 6 (30-byte records, 64-bit count, legacy count 0).
    h = bytearray(head) + bytearray(375 - 227)
    h[25] = 4
    struct.pack_into("<H", h, 94, 375)
    struct.pack_into("<I", h, 96, 375)
    h[104] = 6
    struct.pack_into("<H", h, 105, 30)
    struct.pack_into("<I", h, 107, 0)
    struct.pack_into("<5I", h, 111, 0, 0, 0, 0, 0)
    struct.pack_into("<QIQ", h, 235, 0, 0, 24)  # EVLR start, EVLR count, 64-bit point count
    struct.pack_into("<Q", h, 255, 24)           # points by return: first return
    records = b""
    for k in range(24):
        r = body[k * 28:(k + 1) * 28]
        x, y, z, intensity, ret, cls, angle, user, source, gps = struct.unpack("<iiiHBBbBHd", r)
        records += struct.pack("<iiiHBBBBhHd", x, y, z, intensity, 0x11, 0, cls, user, angle, source, gps)
    put("las", "delft_las14_f6.las", bytes(h) + records)
    # XYZ from the same points, as the header scales them.
    sx, sy, sz, ox, oy, oz = struct.unpack_from("<6d", head, 131)
    lines = []
    for k in range(12):
        x, y, z = struct.unpack_from("<iii", body, k * 28)
        lines.append((x * sx + ox, y * sy + oy, z * sz + oz))
    put("xyz", "delft_space.xyz", "".join(f"{x:.2f} {y:.2f} {z:.2f}\n" for x, y, z in lines))
    put("xyz", "delft_comma_header.xyz", "x,y,z\n" + "".join(f"{x:.3f},{y:.3f},{z:.3f}\n" for x, y, z in lines))
    put("xyz", "delft_tab_crlf.xyz", "# AHN3 Delft\r\n" + "".join(f"{x}\t{y}\t{z}\r\n" for x, y, z in lines[:5]))
    put("xyz", "delft_semicolon.xyz", "".join(f"{x:.1f};{y:.1f};{z:.1f}\n" for x, y, z in lines[:4]))
    put("xyz", "exponents.xyz", "8.5e4 4.46e5 1.5E0\n-0 +1 .5\n")


def mesh_seeds():
    v = [(0, 0, 1.5), (1, 0, 1.6), (2, 0, 1.4), (0, 1, 1.7), (1, 1, 9.5), (2, 1, 1.5), (0, 2, 1.2), (1, 2, 1.3),
         (2, 2, 1.1)]
    f = []
    for r in range(2):
        for c in range(2):
            a = r * 3 + c
            f += [(a, a + 1, a + 4), (a, a + 4, a + 3)]
    crs = "EPSG:28992"
    ply = (f"ply\nformat ascii 1.0\ncomment crs {crs}\nelement vertex {len(v)}\nproperty double x\n"
           f"property double y\nproperty double z\nelement face {len(f)}\nproperty list uchar int vertex_indices\n"
           "end_header\n" + "".join(f"{x} {y} {z}\n" for x, y, z in v) + "".join(f"3 {a} {b} {c}\n" for a, b, c in f))
    put("mesh", "grid3x3_ascii.ply", ply)
    for fmt, endian in [("binary_little_endian", "<"), ("binary_big_endian", ">")]:
        head = (f"ply\nformat {fmt} 1.0\ncomment crs {crs}\nelement vertex {len(v)}\nproperty double x\n"
                "property double y\nproperty double z\nelement face " + str(len(f)) +
                "\nproperty list uchar int vertex_indices\nend_header\n").encode()
        body = b"".join(struct.pack(endian + "3d", *p) for p in v)
        body += b"".join(struct.pack(endian + "B3i", 3, *t) for t in f)
        put("mesh", f"grid3x3_{fmt}.ply", head + body)
    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(v)}\nproperty float x\nproperty float y\n"
            f"property float z\nproperty uchar red\nelement face {len(f)}\nproperty list uint8 uint32 vertex_index\n"
            "end_header\n").encode()
    body = b"".join(struct.pack("<3fB", *p, 7) for p in v) + b"".join(struct.pack("<B3I", 3, *t) for t in f)
    put("mesh", "grid3x3_float_extra.ply", head + body)
    put("mesh", "grid3x3.obj", f"# crs {crs}\no grid\n" + "".join(f"v {x} {y} {z}\n" for x, y, z in v) +
        "vn 0 0 1\nvt 0 0\n" + "".join(f"f {a + 1}/1/1 {b + 1}/1/1 {c + 1}/1/1\n" for a, b, c in f[:4]) +
        "".join(f"f -{9 - a} -{9 - b} -{9 - c}\n" for a, b, c in f[4:]) + "f 1 2 5 4\n")
    put("mesh", "grid3x3.off", f"OFF\n# crs {crs}\n{len(v)} {len(f)} 0\n" + "".join(f"{x} {y} {z}\n" for x, y, z in v) +
        "".join(f"3 {a} {b} {c}\n" for a, b, c in f))
    hostile("mesh", "*.ply")
    hostile("mesh", "mesh_*")


def waypoint_seeds():
    os.makedirs(os.path.join(CORPUS, "waypoints_csv"), exist_ok=True)
    shutil.copy(os.path.join(REPO, "data", "nrw-dom1", "sample_waypoints.csv"), os.path.join(CORPUS, "waypoints_csv"))
    put("waypoints_csv", "comments.csv", "# waypoints\n\nx, y, z\n 356100.5 , 5699100.25,  160\n356200,5699300,1.7e2\n")
    hostile("waypoints_csv", "wp_*.csv")
    put("waypoints_geojson", "collection.geojson",
        '{"type":"FeatureCollection","features":[{"type":"Feature","properties":{},"geometry":'
        '{"type":"Point","coordinates":[7.02,51.45,180.5]}},{"type":"Feature","properties":null,"geometry":'
        '{"type":"MultiPoint","coordinates":[[7.021,51.451,181],[7.022,51.452,182]]}},{"type":"Feature",'
        '"geometry":{"type":"LineString","coordinates":[[7.023,51.453,183],[7.024,51.454,184]]}}]}\n')
    put("waypoints_geojson", "feature.geojson",
        '{"type": "Feature", "properties": {"name": "a"}, "geometry": {"type": "LineString", '
        '"coordinates": [[4.3571, 52.0116, 45.0], [4.3580, 52.0120, 46.5]]}}\n')
    put("waypoints_geojson", "point.geojson", '{"type":"Point","coordinates":[4.3571,52.0116,45]}')
    hostile("waypoints_geojson", "wp_*.geojson")


def airspace_seeds():
    os.makedirs(os.path.join(CORPUS, "airspace"), exist_ok=True)
    for name in ("nrw_zones_ed269.json", "delft_zones.geojson"):
        shutil.copy(os.path.join(REPO, "tests", "data", "airspace", name), os.path.join(CORPUS, "airspace"))
    put("airspace", "circle_feet.json",
        '{"features":[{"identifier":"C","restriction":"PROHIBITED","geometry":[{"uomDimensions":"FT",'
        '"lowerLimit":0,"lowerVerticalReference":"AMSL","upperLimit":400,"upperVerticalReference":"WGS84",'
        '"horizontalProjection":{"type":"Circle","center":[6.9371,51.4289],"radius":300}}]}]}\n')


def roadmap_seeds():
    os.makedirs(os.path.join(CORPUS, "roadmap"), exist_ok=True)
    hostile("roadmap", "*.roadmap")


def index_seeds():
    import subprocess, tempfile
    cli = os.path.join(REPO, "build", "dsmplan")
    if not os.path.exists(cli):
        print("no build/dsmplan: index seeds skipped")
        return
    sample = os.path.join(REPO, "data", "nrw-dom1", "nrw_dom1_crop500m_1m.tif")
    waypoints = os.path.join(REPO, "data", "nrw-dom1", "sample_waypoints.csv")
    os.makedirs(os.path.join(CORPUS, "index"), exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        for res in ("50", "25"):
            mesh = os.path.join(tmp, f"nrw_{res}m.ply")
            subprocess.run([cli, "mesh", sample, "--res", res, "-o", mesh, "-q"], check=True)
            # The index is written once it is built, whether the plan then succeeds or not.
            subprocess.run([cli, "plan", mesh, "--waypoints", waypoints, "-o", os.path.join(tmp, "p.csv"), "-q",
                            "--index", os.path.join(CORPUS, "index", f"nrw_{res}m.index")])


def pipeline_seeds():
    r = random.Random(21)
    for i, size in enumerate([64, 128, 256, 512, 1024, 2048, 4096, 4096]):
        put("pipeline", f"random_{i}_{size}.bin", bytes(r.getrandbits(8) for _ in range(size)))


def camera_seeds():
    """CAMERAS.json: two and three nadir and tilted views over the NRW sample, with and without
    a height range and distortion, and the hostile fixtures' camera files."""
    import json
    nadir = [[1, 0, 0], [0, -1, 0], [0, 0, -1]]
    tilted = [[1, 0, 0], [0, -0.9848, -0.1736], [0, 0.1736, -0.9848]]
    def cam(i, x, rotation, distortion=None):
        c = {"image": "view%d.tif" % i, "width": 1588, "height": 1542, "fx": 4000, "fy": 4000, "cx": 794,
             "cy": 771, "rotation": rotation, "center": [x, 5699500, 400]}
        if distortion:
            c["distortion"] = distortion
        return c
    put("cameras", "two_nadir.json", json.dumps({"crs": "EPSG:25832", "cameras": [
        cam(0, 356500, nadir), cam(1, 356560, nadir)]}))
    put("cameras", "three_tilted_range.json", json.dumps({"crs": "EPSG:25832", "height_range": [115, 155],
        "cameras": [cam(0, 356500, nadir), cam(1, 356560, tilted, [-0.05, 0.01, 0.0001, -0.0002, 0]),
                    cam(2, 356620, nadir)]}))
    hostile("cameras", "cameras_*.json")


def colmap_seeds():
    """COLMAP's text model and the files of its georeference, each a first byte choosing what is
    read (fuzz_colmap.cpp: 0 a model, 1 centres, 2 GCPs, 3 a transform, 4 a model with GCPs, 5 a
    model with centres) then its files separated by NUL bytes: three nadir cameras of each model
    type 30 m apart (COLMAP's quaternion (0, 1, 0, 0): x east, y south, z down), their centres and
    ground control points projected into them, a transform of each form, and the hostile fixtures."""
    params = {"SIMPLE_PINHOLE": "800 320 240", "PINHOLE": "800 790 320 240",
              "SIMPLE_RADIAL": "800 320 240 -0.05", "RADIAL": "800 320 240 -0.05 0.01",
              "OPENCV": "800 790 320 240 -0.05 0.01 0.001 -0.001",
              "FULL_OPENCV": "800 790 320 240 -0.05 0.01 0.001 -0.001 0.002 0 0 0"}
    centres = [(0.0, 0.0, 300.0), (30.0, 0.0, 300.0), (15.0, 25.0, 300.0)]
    images = "# Image list with two lines of data per image:\n" + "".join(
        "%d 0 1 0 0 %r %r %r 1 view%d.tif\n%s\n" % (i + 1, -x, y, z, i, "" if i else "320.5 240.5 -1")
        for i, (x, y, z) in enumerate(centres))
    csv = "image,x,y,z\n" + "".join("view%d.tif,%r,%r,%r\n" % (i, 356300 + x, 5699770 + y, z)
                                    for i, (x, y, z) in enumerate(centres))
    gcps = "point,x,y,z,image,u,v\n"
    for k, (px, py, pz) in enumerate([(5.0, 3.0, 60.0), (25.0, 10.0, 65.0), (12.0, 20.0, 58.0), (18.0, -4.0, 70.0)]):
        for i, (x, y, z) in enumerate(centres):  # pinhole, f 800, centre (319.5, 239.5) in dsmplan's pixels
            depth = z - pz
            u, v = 319.5 + 800 * (px - x) / depth, 239.5 - 800 * (py - y) / depth
            gcps += "P%d,%r,%r,%r,view%d.tif,%r,%r\n" % (k, 356300 + px, 5699770 + py, pz, i, u, v)
    for model, p in params.items():
        cameras = "# Camera list with one line of data per camera:\n1 %s 640 480 %s\n" % (model, p)
        put("colmap", "model_%s.bin" % model.lower(), b"\x00" + cameras.encode() + b"\x00" + images.encode())
    pinhole = "1 PINHOLE 640 480 800 800 320 240\n"
    put("colmap", "centres.bin", b"\x01" + csv.encode())
    put("colmap", "gcps.bin", b"\x02" + gcps.encode())
    put("colmap", "transform_16.bin", b"\x03" + b"1 0 0 356300\n0 1 0 5699770\n0 0 1 0\n0 0 0 1\n")
    put("colmap", "transform_13.bin", b"\x03# s, Q, T\n2\n1 0 0\n0 1 0\n0 0 1\n356300,5699770,0\n")
    put("colmap", "model_gcps.bin", b"\x04" + pinhole.encode() + b"\x00" + images.encode() + b"\x00" + gcps.encode())
    put("colmap", "model_centres.bin", b"\x05" + pinhole.encode() + b"\x00" + images.encode() + b"\x00" +
        csv.encode())
    for path in sorted(glob.glob(os.path.join(HOSTILE, "colmap_*"))):
        name = os.path.basename(path)
        if os.path.isdir(path) and os.path.exists(os.path.join(path, "images.txt")):
            parts = [open(os.path.join(path, f), "rb").read() for f in ("cameras.txt", "images.txt")]
            put("colmap", name + ".bin", b"\x00" + parts[0] + b"\x00" + parts[1])
        elif name.endswith(".csv"):
            put("colmap", name + ".bin", (b"\x02" if "gcps" in name else b"\x01") + open(path, "rb").read())
        elif name.endswith(".txt"):
            put("colmap", name + ".bin", b"\x03" + open(path, "rb").read())


def rpc_seeds():
    """The RPC readers' seeds, each a first byte choosing the file (0 .geom, 1 .RPB, 2 _RPC.TXT)
    then its text: the four real .geom files of data/pleiades-kahramanmaras, and their models
    written as .RPB and _RPC.TXT (GDAL's formats, as GDALLoadRPBFile and GDALLoadRPCFile read)."""
    for geom in sorted(glob.glob(os.path.join(REPO, "data", "pleiades-kahramanmaras", "*.geom"))):
        text = open(geom).read()
        name = os.path.basename(geom)[:-5]
        put("rpc", name + ".geom", b"\x00" + text.encode())
        keys = {}
        for line in text.splitlines():
            if ":" in line:
                k, v = line.split(":", 1)
                keys[k.strip()] = v.strip()
        names = [("line_off", "lineOffset", "LINE_OFF"), ("samp_off", "sampOffset", "SAMP_OFF"),
                 ("lat_off", "latOffset", "LAT_OFF"), ("long_off", "longOffset", "LONG_OFF"),
                 ("height_off", "heightOffset", "HEIGHT_OFF"), ("line_scale", "lineScale", "LINE_SCALE"),
                 ("samp_scale", "sampScale", "SAMP_SCALE"), ("lat_scale", "latScale", "LAT_SCALE"),
                 ("long_scale", "longScale", "LONG_SCALE"), ("height_scale", "heightScale", "HEIGHT_SCALE")]
        groups = [("line_num_coeff", "lineNumCoef", "LINE_NUM_COEFF"), ("line_den_coeff", "lineDenCoef", "LINE_DEN_COEFF"),
                  ("samp_num_coeff", "sampNumCoef", "SAMP_NUM_COEFF"), ("samp_den_coeff", "sampDenCoef", "SAMP_DEN_COEFF")]
        rpb = 'satId = "PHR1A";\nbandId = "P";\nSpecId = "RPC00B";\nBEGIN_GROUP = IMAGE\n\terrBias = 1.0;\n\terrRand = 0.0;\n'
        txt = ""
        for geom_key, rpb_key, txt_key in names:
            rpb += "\t%s = %s;\n" % (rpb_key, keys[geom_key])
            txt += "%s: %s\n" % (txt_key, keys[geom_key])
        for geom_key, rpb_key, txt_key in groups:
            values = [keys["%s_%02d" % (geom_key, i)] for i in range(20)]
            rpb += "\t%s = (\n" % rpb_key + ",\n".join("\t\t\t" + v for v in values) + ");\n"
            txt += "".join("%s_%d: %s\n" % (txt_key, i + 1, v) for i, v in enumerate(values))
        rpb += "END_GROUP = IMAGE\nEND;\n"
        put("rpc", name + ".RPB", b"\x01" + rpb.encode())
        put("rpc", name + "_RPC.TXT", b"\x02" + txt.encode())


if __name__ == "__main__":
    las_seeds()
    hostile("las", "*.las")
    hostile("xyz", "*.xyz")
    mesh_seeds()
    waypoint_seeds()
    roadmap_seeds()
    pipeline_seeds()
    index_seeds()
    camera_seeds()
    colmap_seeds()
    rpc_seeds()
    airspace_seeds()
