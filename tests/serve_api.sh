#!/bin/sh
# serve_api.sh: `hdnet serve` through a real HTTP client (curl), on loopback: upload a PNG and a
# JPEG photo, fetch the maps, relight (preset, direction, 9 coefficients), delight, transfer and
# download light files, each compared byte for byte with what the hdnet command line writes for the
# same photo and light, with the background kept and relit (`--background relight`, and a request
# after one that relit it keeps it again); bad inputs (truncated JPEG, a 60000 x 60000 PNG header, an empty body, a
# wrong content type, a body that is no picture, an upload over the cap, `..` in a path, unknown
# ids, bad JSON, wrong methods) each get their 4xx and the server keeps serving; the least
# recently used photo is evicted and the answer says so; four clients at once get the CLI's
# pixels; a client uploading at 2 kB/s does not hold the others up; SIGINT stops the server
# cleanly (exit 0, which under `make check` also means LeakSanitizer found no leak).
set -u
root=$(cd "$(dirname "$0")/.." && pwd)
HDNET=${HDNET:?HDNET must point at the hdnet tool}
TEST=serve_api
. "$(dirname "$0")/cli_common.shlib"

if ! command -v curl >/dev/null 2>&1; then
    skip "curl is not installed (apt-get install curl)"
fi
if "$HDNET" serve --max-photos 0 2>&1 | grep -q libmicrohttpd; then
    skip "hdnet was built without libmicrohttpd (apt-get install libmicrohttpd-dev, rebuild)"
fi

photo="$root/examples/astronaut.png"
jpeg="$root/tests/data/serve/london-001-neutral.jpg"

# The server: any free port, small caps so that the limits are reached with small files.
"$HDNET" serve --port 0 --max-photos 2 --max-upload 1 --timeout 20 >serve.log 2>&1 &
pid=$!
trap 'kill $pid 2>/dev/null' EXIT
i=0
while ! grep -q 'listening on' serve.log; do
    i=$((i + 1))
    [ $i -le 1200 ] && kill -0 $pid 2>/dev/null || { cat serve.log >&2; fail "the server did not start"; }
    sleep 0.1
done
port=$(sed -n 's|.*http://127\.0\.0\.1:\([0-9]*\)/.*|\1|p' serve.log)
base="http://127.0.0.1:$port"
grep -q 'at most 2' serve.log || fail "the server does not say how many photos it keeps"

# call CODE BODYFILE CURL-ARGS...: one request; checks the status, the answer goes to BODYFILE.
call() {
    want=$1 out=$2
    shift 2
    got=$(curl -s -m 300 -o "$out" -w '%{http_code}' "$@") || fail "curl failed ($?): $*"
    [ "$got" = "$want" ] || { cat "$out" >&2; echo >&2; fail "status $got, expected $want: $*"; }
}
# refused CODE WORDS CURL-ARGS...: a request that must fail with CODE and a JSON error saying WORDS.
refused() {
    want=$1 words=$2
    shift 2
    call "$want" err.json "$@"
    grep -q '"error":' err.json || fail "the $want answer is not a JSON error: $(cat err.json)"
    grep -q -- "$words" err.json || fail "the $want answer does not say '$words': $(cat err.json)"
}
healthy() { call 200 health.json "$base/api/health"; grep -q '"status":"ok"' health.json || fail "health: $(cat health.json)"; }
id_of() { sed -n 's/^{"id":"\([0-9a-f]*\)".*/\1/p' "$1"; }
same() { cmp -s "$1" "$2" || fail "$3: the server's $1 differs from the command line's $2"; }

healthy
grep -q '"max_photos":2' health.json || fail "health does not report the photo limit"

# ---- the page and the presets
call 200 page.html "$base/"
grep -q '<html' page.html || fail "/ is not the page"
call 200 presets.json "$base/api/presets"
[ "$(grep -o '"preset":' presets.json | wc -l)" -eq 7 ] || fail "presets: $(cat presets.json)"

# ---- uploads: a PNG and a JPEG
call 201 up1.json -H 'Content-Type: image/png' --data-binary @"$photo" "$base/api/photos"
id1=$(id_of up1.json)
[ -n "$id1" ] || fail "no id in $(head -c 200 up1.json)"
grep -q '"width":512,"height":512' up1.json || fail "upload: wrong size in $(head -c 200 up1.json)"
grep -q '"box":\[' up1.json && grep -q '"landmarks":\[\[' up1.json && grep -q '"light":\[' up1.json ||
    fail "upload: no face box, landmarks or light"
call 201 up2.json -H 'Content-Type: image/jpeg' --data-binary @"$jpeg" "$base/api/photos"
id2=$(id_of up2.json)
grep -q '"width":675,"height":675' up2.json || fail "JPEG upload: wrong size in $(head -c 200 up2.json)"

# ---- maps: eighteen PNGs of the photo's size, named in the upload's JSON (ten of the background
# kept, seven of it relit, and the faces' depth for their cast shadows, with its code and each face's
# scale)
grep -q '"head":{"window":\[' up1.json || fail "upload: no head window in $(head -c 200 up1.json)"
grep -q '"body_window":\[' up1.json || fail "upload: no head window with the body in $(head -c 200 up1.json)"
grep -q '"depth":{"z0":[-0-9.e]*,"step":0.125}' up1.json || fail "upload: no depth code in $(grep -o '"depth":{[^}]*}' up1.json)"
grep -q '"scale":[0-9.e]*,"landmarks"' up1.json || fail "upload: a face has no scale"
grep -q '"backgrounds":\["keep","relight"\]' up1.json || fail "upload: the background cannot be relit: $(grep -o '"background_reason":"[^"]*"' up1.json)"
for m in photo normal shading mask weight skin head_normal head_proxy head_weights head_mesh \
    body_weight body_level body_head_normal body_head_proxy body_head_weights body_head_mesh people depth; do
    grep -q "\"$m\":\"/api/photos/$id1/maps/$m.png\"" up1.json || fail "the upload's maps do not name $m.png"
    call 200 "$m.png" "$base/api/photos/$id1/maps/$m.png"
    [ "$(png_size "$m.png")" = "512 512" ] || fail "map $m is $(png_size "$m.png"), not 512 512"
done
"$HDNET" info normal.png >info.txt 2>&1 || fail "the normal map is not a readable PNG: $(cat info.txt)"
# the weight map is the render's weight (hd_photo_face_weight, then hd_head_weight) within a level, 0 where it is 0
helper=${BUILD:-$root/build}/tests/serve_weight
[ -x "$helper" ] || fail "$helper is not built (make tests)"
HDNET_DATA=${HDNET_DATA:-$root/models} "$helper" "$photo" weight.png >weight.txt 2>&1 || fail "the weight map: $(cat weight.txt)"
# and with the background relit (hd_face_weights with the people): the body's weight and the people
HDNET_DATA=${HDNET_DATA:-$root/models} "$helper" "$photo" body_weight.png people.png >weight.txt 2>&1 ||
    fail "the body's weight map: $(cat weight.txt)"

# ---- relight: the same bytes as `hdnet relight`
expect 0 "$HDNET" relight "$photo" --preset 1 -o cli_preset1.png
call 200 srv_preset1.png -H 'Content-Type: application/json' -d '{"preset":1}' "$base/api/photos/$id1/relight"
same srv_preset1.png cli_preset1.png "relight preset 1"
expect 0 "$HDNET" relight "$photo" --dir -40,20 --intensity 1.2 --ambient 0.4 -o cli_dir.png
call 200 srv_dir.png -H 'Content-Type: application/json' \
    -d '{"azimuth":-40,"elevation":20,"intensity":1.2,"ambient":0.4}' "$base/api/photos/$id1/relight"
same srv_dir.png cli_dir.png "relight by direction"
expect 0 "$HDNET" light --preset 4 -o p4.txt
coeffs=$(tr '\n' ',' <p4.txt | sed 's/,$//')
expect 0 "$HDNET" relight "$photo" --light p4.txt --no-keep-brightness -o cli_coeffs.png
call 200 srv_coeffs.png -H 'Content-Type: application/json' -d "{\"light\":[$coeffs],\"brightness\":\"free\"}" \
    "$base/api/photos/$id1/relight"
same srv_coeffs.png cli_coeffs.png "relight by coefficients"
cmp -s srv_coeffs.png srv_preset1.png && fail "two lights gave the same picture"
expect 0 "$HDNET" relight "$jpeg" --preset 3 -o cli_jpeg.png
call 200 srv_jpeg.png -H 'Content-Type: application/json' -d '{"preset":3}' "$base/api/photos/$id2/relight"
same srv_jpeg.png cli_jpeg.png "relight of the JPEG"

# ---- the background relit (`--background relight`): relight, delight, transfer; then kept again
expect 0 "$HDNET" relight "$photo" --preset 1 --background relight -o cli_bg.png
call 200 srv_bg.png -H 'Content-Type: application/json' -d '{"preset":1,"background":"relight"}' "$base/api/photos/$id1/relight"
same srv_bg.png cli_bg.png "relight preset 1, the background relit"
cmp -s srv_bg.png srv_preset1.png && fail "the background relit gave the picture of the background kept"
call 200 srv_kept.png -H 'Content-Type: application/json' -d '{"preset":1,"background":"keep"}' "$base/api/photos/$id1/relight"
same srv_kept.png cli_preset1.png "relight preset 1 after one with the background relit"
expect 0 "$HDNET" delight "$photo" --background relight -o cli_bg_delit.png
call 200 srv_bg_delit.png -X POST "$base/api/photos/$id1/delight?background=relight"
same srv_bg_delit.png cli_bg_delit.png "delight, the background relit"
expect 0 "$HDNET" transfer "$photo" --ref "$jpeg" --background relight -o cli_bg_transfer.png
call 200 srv_bg_transfer.png -X POST "$base/api/photos/$id1/transfer?ref=$id2&background=relight"
same srv_bg_transfer.png cli_bg_transfer.png "transfer, the background relit"
call 200 srv_dir2.png -H 'Content-Type: application/json' \
    -d '{"azimuth":-40,"elevation":20,"intensity":1.2,"ambient":0.4}' "$base/api/photos/$id1/relight"
same srv_dir2.png cli_dir.png "relight by direction after a transfer with the background relit"

# ---- delight, transfer, light files
expect 0 "$HDNET" delight "$photo" -o cli_delit.png
call 200 srv_delit.png -X POST "$base/api/photos/$id1/delight"
same srv_delit.png cli_delit.png "delight"
expect 0 "$HDNET" transfer "$photo" --ref "$jpeg" -o cli_transfer.png
call 200 srv_transfer.png -X POST "$base/api/photos/$id1/transfer?ref=$id2"
same srv_transfer.png cli_transfer.png "transfer"
expect 0 "$HDNET" estimate-light "$photo" -o cli_est.txt
call 200 srv_est.txt "$base/api/photos/$id1/light.txt"
same srv_est.txt cli_est.txt "the photo's light file"
expect 0 "$HDNET" light --preset 3 -o cli_p3.txt
call 200 srv_p3.txt "$base/api/light.txt?preset=3"
same srv_p3.txt cli_p3.txt "a preset's light file"
expect 0 "$HDNET" light --dir 30,-10 --intensity 2 --ambient 0.3 -o cli_d.txt
call 200 srv_d.txt "$base/api/light.txt?azimuth=30&elevation=-10&intensity=2&ambient=0.3"
same srv_d.txt cli_d.txt "a direction's light file"

# ---- four clients at once: every answer is the command line's
clients=""
for k in 1 2 3 4; do
    curl -s -m 600 -o "par$k.png" -w '%{http_code}' -H 'Content-Type: application/json' -d '{"preset":1}' \
        "$base/api/photos/$id1/relight" >"par$k.code" &
    clients="$clients $!"
done
for j in $clients; do wait "$j"; done
for k in 1 2 3 4; do
    [ "$(cat "par$k.code")" = 200 ] || fail "parallel client $k got status $(cat "par$k.code")"
    same "par$k.png" cli_preset1.png "parallel relight $k"
done

# ---- bad inputs: each its 4xx, and the server goes on
head -c 20000 "$jpeg" >truncated.jpg
refused 400 "JPEG" -H 'Content-Type: image/jpeg' --data-binary @truncated.jpg "$base/api/photos"
healthy
# a PNG signature and an IHDR chunk (CRC correct) claiming 60000 x 60000 RGB, then nothing
printf '\211PNG\r\n\032\n\000\000\000\015IHDR\000\000\352\140\000\000\352\140\010\002\000\000\000\017\260\342\025' >huge.png
refused 413 "pixels" -H 'Content-Type: image/png' --data-binary @huge.png "$base/api/photos"
healthy
refused 400 "empty" -H 'Content-Type: image/png' --data-binary @/dev/null "$base/api/photos"
refused 415 "image/png" -H 'Content-Type: text/plain' --data-binary @"$photo" "$base/api/photos"
refused 415 "image/png" --data-binary @"$photo" "$base/api/photos" # curl's default form type
printf 'GIF89a not a photo' >fake.png
refused 415 "not a PNG or JPEG" -H 'Content-Type: image/png' --data-binary @fake.png "$base/api/photos"
head -c 1100000 /dev/zero >big.bin
refused 413 "limit" -H 'Content-Type: image/png' --data-binary @big.bin "$base/api/photos"
expect 0 "$HDNET" light --preset 0 -o p0.txt --preview noface.png --size 96
refused 422 "no face" -H 'Content-Type: image/png' --data-binary @noface.png "$base/api/photos"
healthy
refused 400 "bad path" --path-as-is "$base/api/photos/../../etc/passwd"
refused 400 "bad path" --path-as-is "$base/../Makefile"
refused 400 "bad path" --path-as-is "$base/api/photos/$id1/maps/..%2f..%2fMakefile"
refused 404 "not found" "$base/etc/passwd"
refused 404 "no photo" "$base/api/photos/0123456789abcdef/maps/normal.png"
refused 404 "no photo" "$base/api/photos/nonsense/relight"
refused 404 "no map" "$base/api/photos/$id1/maps/albedo.png"
refused 404 "no photo" -X POST "$base/api/photos/$id1/transfer?ref=0123456789abcdef"
refused 400 "ref" -X POST "$base/api/photos/$id1/transfer"
refused 400 "JSON" -H 'Content-Type: application/json' -d '{"preset":' "$base/api/photos/$id1/relight"
refused 400 "preset" -H 'Content-Type: application/json' -d '{"preset":9}' "$base/api/photos/$id1/relight"
refused 400 "finite" -H 'Content-Type: application/json' -d '{"azimuth":"left","elevation":0}' "$base/api/photos/$id1/relight"
refused 400 "exactly one" -H 'Content-Type: application/json' -d '{}' "$base/api/photos/$id1/relight"
refused 400 "background" -H 'Content-Type: application/json' -d '{"preset":1,"background":"wall"}' "$base/api/photos/$id1/relight"
refused 400 "background" -H 'Content-Type: application/json' -d '{"preset":1,"background":true}' "$base/api/photos/$id1/relight"
refused 400 "JSON body" -H 'Content-Type: application/json' -d '{"preset":1}' "$base/api/photos/$id1/relight?background=relight"
refused 400 "background" -X POST "$base/api/photos/$id1/delight?background=yes"
refused 400 "background" -X POST "$base/api/photos/$id1/transfer?ref=$id2&background="
refused 415 "json" -H 'Content-Type: text/plain' -d '{"preset":1}' "$base/api/photos/$id1/relight"
refused 405 "POST" "$base/api/photos/$id1/relight"
refused 405 "POST" "$base/api/photos"
refused 400 "face" "$base/api/photos/$id1/light.txt?face=3"
refused 400 "preset" "$base/api/light.txt?preset=7"
refused 403 "localhost" -H 'Host: attacker.example' "$base/api/health"
healthy

# ---- a slow client (2 kB/s upload: 790 kB take 6 minutes) does not hold up the others: a relight
# ends while the slow upload is still going on
curl -s -m 600 --limit-rate 2k -o /dev/null -H 'Content-Type: image/png' --data-binary @"$photo" "$base/api/photos" &
slow=$!
sleep 1
call 200 during.png -H 'Content-Type: application/json' -d '{"preset":1}' "$base/api/photos/$id1/relight"
kill -0 $slow 2>/dev/null || fail "the slow upload ended before the relight beside it"
same during.png cli_preset1.png "relight during a slow upload"
kill $slow 2>/dev/null
wait $slow 2>/dev/null

# ---- at most 2 photos: the least recently used goes, and the answer says which
call 200 touch.json "$base/api/photos/$id1" # id1 is now more recent than id2
call 201 up3.json -H 'Content-Type: image/png' --data-binary @"$photo" "$base/api/photos"
grep -q "\"evicted\":\"$id2\"" up3.json || fail "the third upload did not evict $id2: $(head -c 300 up3.json)"
refused 404 "evicted" "$base/api/photos/$id2/maps/photo.png"
call 200 again.png "$base/api/photos/$id1/maps/photo.png"
call 200 delete.json -X DELETE "$base/api/photos/$id1"
refused 404 "no photo" "$base/api/photos/$id1"
healthy

# ---- Ctrl-C: a clean stop
kill -INT $pid
i=0
while kill -0 $pid 2>/dev/null; do
    i=$((i + 1))
    [ $i -le 1200 ] || fail "the server did not stop within 120 s of SIGINT"
    sleep 0.1
done
wait $pid
code=$?
trap - EXIT
[ $code -eq 0 ] || { cat serve.log >&2; fail "the server exited with status $code after SIGINT"; }
grep -q 'stopped' serve.log || fail "the server did not say it stopped"
echo "serve_api: ok (port $port; relight, delight, transfer and light files equal the CLI's)"
