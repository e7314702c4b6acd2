/*
 * A replay loop in C over fog.h: what a gyro's or an IMU's C firmware does per sample, run over a
 * file.
 *
 *   fog_replay model.bin samples.bin out.bin
 *
 * model.bin is a blob `trainer fit` wrote: a unit's channels (an IMU's gyro and accelerometer
 * axes), or one model, which loads as a unit of one channel. samples.bin holds one record per
 * sample: time f64, temperature f32, the first channel's output f32, flags u32 with bit 0 set at a
 * power-on, then the other channels' outputs f32 (all little-endian), as `firmware-sim` writes
 * them for the Cortex-M4 image. out.bin gets one 9-byte record per channel per sample: mean f32,
 * bias variance f32, status u8. Both formats are firmware-core's `record` module. Exit status 0
 * on success, 1 with a message on stderr.
 *
 * Build on the host, after `cargo build -p fog-ffi --release`:
 *   cc -O2 -I firmware-core/ffi/include firmware-core/ffi/include/fog_replay.c \
 *      target/release/libfog_ffi.a -lm -lpthread -ldl -o fog_replay
 * and for the Cortex-M4F under QEMU: docs/firmware.md, "Firmware in C".
 */
#include <inttypes.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "fog.h"

/* Static storage, as on the gyro: nothing is allocated. One state for the whole unit: its
 * channels share the temperature features. */
static FogUnit unit;
static FogState state;
static uint8_t blob[8 * FOG_UNIT_WORDS];

static int fail(const char *what) {
    fprintf(stderr, "fog_replay: %s\n", what);
    return 1;
}

/* The little-endian bytes at p, as the host's own types (this program assumes a little-endian
 * host, as the Cortex-M4 is). */
static double f64_at(const uint8_t *p) { double v; memcpy(&v, p, 8); return v; }
static float f32_at(const uint8_t *p) { float v; memcpy(&v, p, 4); return v; }
static uint32_t u32_at(const uint8_t *p) { uint32_t v; memcpy(&v, p, 4); return v; }

int main(int argc, char **argv) {
    if (argc != 4) {
        return fail("usage: fog_replay model.bin samples.bin out.bin");
    }
    if (FOG_ABI_CHECK() != FOG_OK) {
        return fail("the library was built against another fog.h");
    }
    FILE *f = fopen(argv[1], "rb");
    if (!f) {
        return fail("cannot open the model");
    }
    size_t len = fread(blob, 1, sizeof blob, f);
    fclose(f);
    FogResult r = fog_unit_decode(&unit, blob, len);
    if (r != FOG_OK) {
        fprintf(stderr, "fog_replay: model refused (FogResult %d)\n", (int)r);
        return 1;
    }
    FogUnitInfo info;
    if (fog_unit_info(&unit, &info) != FOG_OK) {
        return fail("no unit");
    }
    uint32_t c = info.channels;
    for (uint32_t k = 0; k < c; k++) {
        FogChannelInfo ch;
        if (fog_unit_channel(&unit, k, &ch) != FOG_OK) {
            return fail("no channel");
        }
        fprintf(stderr, "fog_replay: %s: %" PRIu32 " centres, %" PRIu32 " inputs\n",
                (const char *)ch.name, ch.dims.centres, ch.dims.inputs);
    }

    FILE *in = fopen(argv[2], "rb");
    FILE *out = fopen(argv[3], "wb");
    if (!in || !out) {
        return fail("cannot open the samples or the output");
    }
    fog_state_reset(&state);
    uint8_t rec[20 + 4 * (FOG_UNIT_MAX_CHANNELS - 1)];
    size_t rec_len = 20 + 4 * (c - 1);
    while (fread(rec, 1, rec_len, in) == rec_len) {
        if (u32_at(rec + 16) & 1u) {
            fog_state_power_on(&state); /* power-on, the state kept through the power-off */
        }
        float outputs[FOG_UNIT_MAX_CHANNELS];
        outputs[0] = f32_at(rec + 12);
        for (uint32_t k = 1; k < c; k++) {
            outputs[k] = f32_at(rec + 20 + 4 * (k - 1));
        }
        FogPrediction p[FOG_UNIT_MAX_CHANNELS];
        r = fog_unit_compensate(&unit, &state, f64_at(rec), f32_at(rec + 8), outputs, c, p,
                                FOG_UNIT_MAX_CHANNELS);
        if (r != FOG_OK) {
            fprintf(stderr, "fog_replay: compensate failed (FogResult %d)\n", (int)r);
            return 1;
        }
        for (uint32_t k = 0; k < c; k++) {
            uint8_t res[9];
            memcpy(res, &p[k].mean, 4);
            memcpy(res + 4, &p[k].bias_variance, 4);
            res[8] = (uint8_t)p[k].status;
            if (fwrite(res, 1, sizeof res, out) != sizeof res) {
                return fail("write error");
            }
        }
    }
    fclose(in);
    return fclose(out) == 0 ? 0 : fail("write error");
}
