#!/usr/bin/env bash
# The main job on the bundled real sample (500 m x 500 m of the NRW DOM1, 1 m cells), into
# out/sample/: describe the DSM, build the paper's XY-3 Delaunay mesh at 1 m and 2 m, simplify
# it by the paper's variants one and two and by the conservative bounded mode (each certified
# against the DSM), draw the three side by side as the paper's Figures 6 and 7, and plan a
# collision-free path through the bundled waypoints on the conservative mesh, and a low-altitude
# mission under a 30 m ceiling drawn from above and from the side (both limits held), and a
# mission between the buildings of Delft under a ceiling counted from the terrain (AHN3 LiDAR),
# and a DSM made from four aerial views rendered from the sample (dsmplan stereo), scored against
# the sample and meshed, simplified and planned on like it; and the same views through COLMAP's
# structure-from-motion (dsmplan stereo --colmap) when colmap is installed by then.
#
# Builds only what it runs (dsmplan, bench/aerial_sample). COLMAP, a large desktop dependency
# set, is installed in the background while dsmplan builds (log: out/sample/colmap-install.log);
# its step is skipped with a note when the install is not done by then, and runs next time.
set -euo pipefail
cd "$(dirname "$0")/.."
dsm=data/nrw-dom1/nrw_dom1_crop500m_1m.tif
out=out/sample
mkdir -p "$out"
scripts/deps.sh  # in the foreground first: one apt-get at a time
colmap_install=""
if ! command -v colmap > /dev/null 2>&1; then
  scripts/deps.sh colmap > "$out/colmap-install.log" 2>&1 &
  colmap_install=$!
fi
DSMPLAN_TARGETS="dsmplan aerial_sample" scripts/build.sh
build/dsmplan info "$dsm" | tee "$out/info.txt"
build/dsmplan info "$dsm" --json > "$out/info.json"
for res in 1 2; do
  echo "Meshing at ${res} m:"
  build/dsmplan mesh "$dsm" --res "$res" -o "$out/mesh_${res}m.ply" --stats "$out/mesh_${res}m.json"
done
echo
echo "Simplifying at 1 m (the paper's dz = 0.4 m, dco = 1e-5 m; bounded: E = 0.4 m, never below the DSM):"
for method in variant1 variant2; do
  build/dsmplan simplify "$dsm" --method "$method" -o "$out/${method}_1m.ply" --stats "$out/${method}_1m.json" -q
done
build/dsmplan simplify "$dsm" --max-error 0.4 --conservative -o "$out/bounded_1m.ply" \
  --stats "$out/bounded_1m.json" -q
# The same as glTF for 3D viewers, with a 3D Tiles tileset.json that puts it on the globe in
# CesiumJS (heights DHHN2016, taken as EGM96: PROJ has no GCG2016 grid).
build/dsmplan simplify "$dsm" --max-error 0.4 --conservative -o "$out/bounded_1m.glb" --3dtiles \
  --vertical-crs EPSG:7837 --allow-approximate-vertical -q >/dev/null
echo
echo "Drawing a 150 m crop of the three meshes side by side (the paper's Figs 6 and 7):"
build/dsmplan render "$dsm" --window 356500,5699450,356650,5699600 --zoom 4 \
  --mesh "$out/variant1_1m.ply" --title "variant one" \
  --mesh "$out/variant2_1m.ply" --title "variant two" \
  --mesh "$out/bounded_1m.ply" --title "bounded, conservative 0.4 m" \
  -o "$out/simplify_1m.png" -q
echo
echo "Planning a path through the bundled waypoints on the conservative mesh (2 m safety distance):"
# The roadmap is built by the first query and reused by the second (a new mesh needs a new one).
rm -f "$out/bounded_1m.roadmap"
build/dsmplan plan "$out/bounded_1m.ply" --waypoints data/nrw-dom1/sample_waypoints.csv \
  -o "$out/path.csv" --roadmap "$out/bounded_1m.roadmap" --dsm "$dsm" --stats "$out/path.json"
# The sample's heights are DHHN2016; without the GCG2016 geoid grid PROJ could only copy them
# ("ballpark", 47 m off on the ellipsoid): allowed explicitly, they are taken as EGM96 heights
# instead, about a metre off in every format. Each file names that.
for format in geojson plan waypoints kml; do
  build/dsmplan plan "$out/bounded_1m.ply" --waypoints data/nrw-dom1/sample_waypoints.csv \
    -o "$out/path.$format" --roadmap "$out/bounded_1m.roadmap" --dsm "$dsm" \
    --vertical-crs EPSG:7837 --allow-approximate-vertical -q
done
echo
echo "A low-altitude mission: four street points 6-12 m above the streets, a 30 m ceiling over every point"
echo "of the path, 2 m from the DSM's cells as solid columns (checked on what is written):"
build/dsmplan plan "$out/bounded_1m.ply" --waypoints data/nrw-dom1/low_waypoints.csv -o "$out/low_path.csv" \
  --dsm "$dsm" --max-agl 30 --spacing 10 --stats "$out/low_path.json"
build/dsmplan render "$dsm" --mesh "$out/bounded_1m.ply" --no-edges --path "$out/low_path.csv" \
  --waypoints data/nrw-dom1/low_waypoints.csv --window 356300,5699250,356800,5699650 --zoom 2 \
  --title "low-altitude mission, --max-agl 30" -o "$out/low_path.png" -q
build/dsmplan profile "$dsm" --path "$out/low_path.csv" --waypoints data/nrw-dom1/low_waypoints.csv \
  --safety 2 --max-agl 30 --title "low-altitude mission: side view" -o "$out/low_profile.png"
echo
echo "A mission between buildings (Delft, AHN3 LiDAR): the DSM and the terrain (ground points, class 2)"
echo "gridded from the LAZ files, a ceiling 10 m above the terrain, below the roofs, so the legs go"
echo "around the blocks, 2 m from the DSM's cells as solid columns:"
# At --max-agl 30 a drone may cross every roof of this town (10-20 m): flying between the blocks
# takes a ceiling below them, counted from the terrain, not from the roofs (--dtm).
delft="data/delft-ahn3/ahn3_cropped_1.laz data/delft-ahn3/ahn3_cropped_2.laz"
build/dsmplan grid $delft --crs EPSG:7415 --res 1 -o "$out/delft_dsm.tif" -q
build/dsmplan grid $delft --crs EPSG:7415 --res 1 --classes 2 --fill-holes 30 -o "$out/delft_dtm.tif" -q
build/dsmplan simplify "$out/delft_dsm.tif" --max-error 0.4 --conservative -o "$out/delft_bounded.ply" -q
build/dsmplan plan "$out/delft_bounded.ply" --dsm "$out/delft_dsm.tif" --dtm "$out/delft_dtm.tif" \
  --waypoints data/delft-ahn3/low_waypoints.csv --max-agl 10 --spacing 4 \
  -o "$out/delft_path.csv" --stats "$out/delft_path.json" -q
build/dsmplan render "$out/delft_dsm.tif" --mesh "$out/delft_bounded.ply" --no-edges --path "$out/delft_path.csv" \
  --waypoints data/delft-ahn3/low_waypoints.csv --zoom 3 \
  --title "between buildings, DTM + 10 m" -o "$out/delft_path.png" -q
build/dsmplan profile "$out/delft_dsm.tif" --dtm "$out/delft_dtm.tif" --path "$out/delft_path.csv" \
  --waypoints data/delft-ahn3/low_waypoints.csv --safety 2 --max-agl 10 \
  --title "between buildings: side view" -o "$out/delft_profile.png"
echo
echo "From images (dsmplan stereo): four aerial views rendered from the sample's central 140 m (cells as solid"
echo "columns, two strips of two, one view tilted with lens distortion), matched pair by pair by SGM, the median"
echo "per 1 m cell (the height range estimated from the images); scored against the DSM they were rendered from,"
echo "then meshed, simplified and planned on like the real DSM:"
aerial="$out/aerial"
build/bench/aerial_sample render "$aerial"
build/dsmplan stereo --cameras "$aerial/cameras.json" -o "$out/stereo_dsm.tif" --res 1 \
  --bounds "$(cat "$aerial/bounds.txt")" --stats "$out/stereo_dsm.json"
build/bench/aerial_sample score "$out/stereo_dsm.tif" "$aerial/truth.tif"
build/dsmplan mesh "$out/stereo_dsm.tif" -o "$out/stereo_mesh.ply" --stats "$out/stereo_mesh.json" -q
build/dsmplan simplify "$out/stereo_dsm.tif" --max-error 0.4 --conservative -o "$out/stereo_bounded.ply" \
  --stats "$out/stereo_bounded.json" -q
build/dsmplan plan "$out/stereo_bounded.ply" --waypoints "$aerial/waypoints.csv" --dsm "$out/stereo_dsm.tif" \
  --spacing 5 -o "$out/stereo_path.csv" --stats "$out/stereo_path.json" -q
# The same views through structure-from-motion (issue 34, point 4): COLMAP finds the poses itself
# on the CPU; dsmplan puts its model into EPSG:25832 by the cameras' centres and makes the DSM.
echo
colmap_route=0
if [ -n "$colmap_install" ] && kill -0 "$colmap_install" 2> /dev/null; then
  echo "The COLMAP route (dsmplan stereo --colmap) is skipped: COLMAP is still installing in the background" \
    "($out/colmap-install.log); run scripts/sample.sh again once it is done."
elif command -v colmap > /dev/null 2>&1; then
  echo "From images by structure-from-motion: six more views of the same scene (3 x 2, no lens distortion; the"
  echo "four above have a distorted one, which COLMAP given only the focal length cannot model), COLMAP on the"
  echo "CPU (SIFT, exhaustive matching, mapper; the focal length given, the poses its own), then"
  echo "dsmplan stereo --colmap with the cameras' centres; scored as above:"
  sfm="$out/colmap"
  rm -rf "$sfm" && mkdir -p "$sfm/sparse" "$sfm/model"
  log="$sfm/colmap.log"
  export QT_QPA_PLATFORM=offscreen
  colmap feature_extractor --database_path "$sfm/colmap.db" --image_path "$aerial/sfm" \
    --ImageReader.camera_model PINHOLE --ImageReader.single_camera 1 --ImageReader.camera_params 495,495,240,240 \
    --SiftExtraction.use_gpu 0 --SiftExtraction.num_threads 2 > "$log" 2>&1
  colmap exhaustive_matcher --database_path "$sfm/colmap.db" --SiftMatching.use_gpu 0 \
    --SiftMatching.num_threads 2 >> "$log" 2>&1
  colmap mapper --database_path "$sfm/colmap.db" --image_path "$aerial/sfm" --output_path "$sfm/sparse" \
    --Mapper.num_threads 2 --Mapper.ba_refine_focal_length 0 --Mapper.ba_refine_principal_point 0 \
    --Mapper.ba_refine_extra_params 0 >> "$log" 2>&1
  colmap model_converter --input_path "$sfm/sparse/0" --output_path "$sfm/model" --output_type TXT >> "$log" 2>&1
  build/dsmplan stereo --colmap "$sfm/model" --centres "$aerial/sfm/centres.csv" --crs EPSG:25832 \
    --images "$aerial/sfm" -o "$out/colmap_dsm.tif" --res 1 --bounds "$(cat "$aerial/bounds.txt")" \
    --stats "$out/colmap_dsm.json"
  build/bench/aerial_sample score "$out/colmap_dsm.tif" "$aerial/truth.tif"
  colmap_route=1
else
  echo "The COLMAP route (dsmplan stereo --colmap) is skipped: scripts/deps.sh colmap could not install colmap" \
    "($out/colmap-install.log)."
fi
build/dsmplan render "$dsm" --mesh "$out/bounded_1m.ply" --no-edges --roadmap "$out/bounded_1m.roadmap" \
  --path "$out/path.csv" --waypoints data/nrw-dom1/sample_waypoints.csv --zoom 2 \
  --title "path over the conservative mesh, roadmap in blue" -o "$out/path.png" -q
# The paper's metrics in one table, read from the --stats files (one JSON key a line).
value() { sed -n "s/^ *\"$2\": \([^,]*\),\{0,1\}$/\1/p" "$1" | head -n 1; }
echo
echo "Summary (the sample: $(value "$out/mesh_1m.json" vertices) cells at 1 m)"
printf '| %-28s | %9s | %6s | %24s |\n' mesh vertices kept "certified above / below"
printf '|%s|%s|%s|%s|\n' ------------------------------ ----------- -------- --------------------------
cells=$(value "$out/mesh_1m.json" vertices)
printf '| %-28s | %9s | %5s%% | %24s |\n' "XY-3 mesh (Section 3)" "$cells" 100 "0 (through every centre)"
for run in variant1:"variant one, dz 0.4" variant2:"variant two, dz 0.4" bounded:"bounded, conservative 0.4 m"; do
  f="$out/${run%%:*}_1m.json"
  kept=$(value "$f" vertices_out)
  printf '| %-28s | %9s | %5s%% | %24s |\n' "${run#*:}" "$kept" "$((100 * kept / cells))" \
    "$(printf '+%.2f / -%.2f' "$(value "$f" max_above_m)" "$(value "$f" max_below_m)")"
done
echo
printf 'Path (bounded mesh, 3 waypoints): %.1f m; clearance %.2f m to the mesh, %.2f m to the DSM columns (--safety 2); roadmap %s nodes, %s edges\n' \
  "$(value "$out/path.json" path_length_m)" "$(value "$out/path.json" min_clearance_m)" \
  "$(value "$out/path.json" min_clearance_dsm_m)" \
  "$(value "$out/path.json" roadmap_nodes)" "$(value "$out/path.json" roadmap_edges)"
printf 'Low-altitude mission (4 waypoints): %.1f m; %.2f m from the DSM columns (--safety 2), at most %.2f m above the DSM cell below (--max-agl 30)\n' \
  "$(value "$out/low_path.json" path_length_m)" "$(value "$out/low_path.json" min_clearance_dsm_m)" \
  "$(value "$out/low_path.json" max_agl_m)"
printf 'Between buildings, Delft (4 waypoints): %.1f m; %.2f m from the DSM columns (--safety 2), at most %.2f m above the terrain (--max-agl 10)\n' \
  "$(value "$out/delft_path.json" path_length_m)" "$(value "$out/delft_path.json" min_clearance_dsm_m)" \
  "$(value "$out/delft_path.json" max_agl_m)"
printf 'From images (4 rendered views, dsmplan stereo): %s of %s cells filled; XY-3 mesh %s vertices, bounded %s; path %.1f m, %.2f m from the DSM columns\n' \
  "$(value "$out/stereo_dsm.json" valid)" \
  "$(value "$out/stereo_dsm.json" cells)" "$(value "$out/stereo_mesh.json" vertices)" \
  "$(value "$out/stereo_bounded.json" vertices_out)" "$(value "$out/stereo_path.json" path_length_m)" \
  "$(value "$out/stereo_path.json" min_clearance_dsm_m)"
[ "$colmap_route" = 1 ] && printf 'From 6 views through COLMAP (dsmplan stereo --colmap): %s of %s cells filled; fit to the centres RMS %.3f m\n' \
  "$(value "$out/colmap_dsm.json" valid)" "$(value "$out/colmap_dsm.json" cells)" \
  "$(value "$out/colmap_dsm.json" residual_rms)"
echo
echo "Outputs in $out/:"
ls -l "$out"
echo
echo "To see the conservative mesh and the path in 3D in a browser (serves until Ctrl-C; scripts/build.sh"
echo "installs the viewer's three.js first, scripts/test.sh does too):"
echo "  scripts/build.sh && build/dsmplan view $out/bounded_1m.glb --path $out/path.csv \\"
echo "    --waypoints data/nrw-dom1/sample_waypoints.csv"
