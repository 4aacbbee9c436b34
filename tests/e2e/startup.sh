# A process loads OpenImageIO (through libphotonbench_image_io.so, beside libphotonbench.so) only when
# it reads or writes an image: its 260 shared libraries were 90% of every process's start
# (io/image.h, ImageCodec), paid by every validate, schema, list and test process.
source "$(dirname "$0")/lib.bash"
# A build with -DPB_IMAGE_CODEC_MODULE=OFF links OpenImageIO into the library.
if readelf -d "$(dirname "$PB")/libphotonbench.so" | grep -q "NEEDED.*libOpenImageIO"; then
  echo "skipped: this build links the image codec into libphotonbench (PB_IMAGE_CODEC_MODULE=OFF)"
  exit 77
fi
loaded() { printf '%s\n' "$1" | grep -c "calling init: .*libOpenImageIO\.so" || true; }
cfg="$WORK/config.yaml"
write_config "$cfg" "scenes: [cornell-box]"

OUT="$(LD_DEBUG=libs "$PB" validate "$cfg" 2>&1)" && pass "validate runs" || fail "validate: $OUT"
[ "$(loaded "$OUT")" -eq 0 ] && pass "validate loads no OpenImageIO" || fail "validate loaded OpenImageIO"
OUT="$(LD_DEBUG=libs "$PB" --version 2>&1)"
[ "$(loaded "$OUT")" -eq 0 ] && pass "--version loads no OpenImageIO" || fail "--version loaded OpenImageIO"

data="$SRC/tests/data/metrics"
OUT="$(LD_DEBUG=libs "$PB" metrics --reference "$data/ldr01_ref.png" --test "$data/ldr01_test.png" \
  --error-map "$WORK/err.png" 2>&1)" && pass "metrics reads and writes images" || fail "metrics: $OUT"
[ "$(loaded "$OUT")" -ge 1 ] && pass "reading an image loads OpenImageIO" || fail "no OpenImageIO after reading an image"
printf '%s\n' "$OUT" | grep -q "calling init: .*/libphotonbench_image_io\.so" &&
  pass "the codec module is loaded" || fail "libphotonbench_image_io.so was not loaded"
[ -s "$WORK/err.png" ] && pass "the error map is written" || fail "no error map"
finish
