#!/bin/bash
# with_simd.sh PATH TEST [ARGS...]: run TEST with the evaluators forced onto
# SIMD path PATH (IVOCT_SIMD), or skip it (exit 77, ctest's SKIP_RETURN_CODE)
# when this CPU cannot run that path: ivoct itself refuses a path it cannot run.
path=$1
shift
if ! IVOCT_SIMD=$path "$IVOCT_BIN" --version > /dev/null 2>&1; then
    echo "SIMD path $path: this CPU cannot run it; skipped"
    exit 77
fi
IVOCT_SIMD=$path exec "$@"
