/*
 * The C interface's promises, checked from C as a gyro's firmware calls it (issue 46):
 *
 *   fog_selftest model.bin [step]
 *
 * - the library was built against this header (FOG_ABI_CHECK), and a caller built against
 *   other capacities is told so;
 * - a failed decode, for any reason (a null blob included), leaves no model;
 * - a slot layout that does not fit the device is refused before anything is read, erased or
 *   programmed;
 * - with a flash driver that fails any one read, erase or program and then loses power at any
 *   byte of the update's work (every `step`-th), the next boot has the old model or the new one,
 *   never none and never an older one; a boot whose read fails says so rather than boot the
 *   older slot;
 * - a time that goes back after fog_state_power_on (a time since power-on passed where a running
 *   clock was wanted), or does not move at all, is flagged FOG_DEGRADED, not a silent reset.
 *
 * The flash is NOR in RAM: an erase sets a 4 KiB sector to 0xFF byte by byte, a program clears
 * bits within a 256-byte page, and a power cut leaves the byte it falls on half done and stops
 * every later erase and program (firmware-sim's NorFlash does the same for the Rust tests). Built
 * for the host and for the Cortex-M4F (QEMU) by the tests, with -fshort-enums and without: the
 * header's static assertions hold the enums to 32 bits either way. Exit status 0 when every check
 * holds; 1 with the failures on stderr.
 */
#include <inttypes.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fog.h"

#define SECTOR 4096u
#define PAGE 256u
#define SIZE (4u * SECTOR)

typedef struct {
    uint8_t cells[SIZE];
    long budget; /* bytes of erase or program work before the power goes; -1: no cut */
    int powered;
    long ops;     /* operations since the last arm() */
    long fail_at; /* the operation that fails once; -1: none */
    long worked;  /* bytes erased or programmed */
} Nor;

static Nor dev, snapshot;
static FogModel model;
static FogState state;
static uint8_t buf[2 * SECTOR];
static uint8_t blob[2 * SECTOR];
static uint8_t work_blob[2 * SECTOR];
static size_t blob_len;
static long checks, failures, cases;

static void check(int ok, const char *what, long a, long b) {
    checks++;
    if (!ok) {
        failures++;
        if (failures <= 20) {
            fprintf(stderr, "fog_selftest: FAILED %s (%ld, %ld)\n", what, a, b);
        }
    }
}

static int fails(Nor *d) { return d->ops++ == d->fail_at; }

static int32_t nor_read(void *ctx, uint32_t addr, uint8_t *out, size_t len) {
    Nor *d = ctx;
    if (fails(d)) {
        return 2;
    }
    if (addr > SIZE || len > SIZE - addr) {
        return 1;
    }
    memcpy(out, d->cells + addr, len);
    return 0;
}

/* One byte of work: `full` when the power holds; on the byte it goes, half of it. */
static int work(Nor *d, uint32_t addr, uint8_t full, uint8_t half) {
    if (d->budget == 0) {
        d->cells[addr] = half;
        d->powered = 0;
        return 0;
    }
    if (d->budget > 0) {
        d->budget--;
    }
    d->cells[addr] = full;
    d->worked++;
    return 1;
}

static int32_t nor_erase(void *ctx, uint32_t addr) {
    Nor *d = ctx;
    if (addr % SECTOR != 0 || addr > SIZE - SECTOR) {
        return 1;
    }
    if (fails(d) || !d->powered) {
        return 2;
    }
    for (uint32_t a = addr; a < addr + SECTOR; a++) {
        if (!work(d, a, 0xFF, d->cells[a] | 0x0F)) {
            return 2;
        }
    }
    return 0;
}

static int32_t nor_program(void *ctx, uint32_t addr, const uint8_t *data, size_t len) {
    Nor *d = ctx;
    if (addr > SIZE || len > SIZE - addr || (len > 0 && addr / PAGE != (addr + len - 1) / PAGE)) {
        return 1;
    }
    if (fails(d) || !d->powered) {
        return 2;
    }
    for (size_t i = 0; i < len; i++) {
        uint8_t c = d->cells[addr + i];
        if (!work(d, addr + i, c & data[i], c & (data[i] | 0xF0))) {
            return 2;
        }
    }
    return 0;
}

static FogFlash flash = {&dev, SIZE, SECTOR, PAGE, nor_read, nor_erase, nor_program};
static const FogLayout LAYOUT = {0, SECTOR, SECTOR};

/* The device with no cut and no failure pending, its counters at zero. */
static void arm(long fail_at, long budget) {
    dev.ops = 0;
    dev.worked = 0;
    dev.fail_at = fail_at;
    dev.budget = budget;
    dev.powered = 1;
}

static FogResult update(const FogLayout *layout) {
    memcpy(work_blob, blob, blob_len);
    FogSlot slot;
    return fog_slots_update(&flash, layout, work_blob, blob_len, buf, sizeof buf, &slot);
}

/* Boots; the sequence booted, or -(result) where nothing was. */
static long boot(const FogLayout *layout) {
    FogSlot slot;
    FogResult r = fog_slots_boot(&flash, layout, buf, sizeof buf, &model, &slot);
    return r == FOG_OK ? (long)slot.sequence : -(long)r;
}

static int has_model(void) {
    FogDims dims;
    return fog_model_dims(&model, &dims) == FOG_OK;
}

static void abi(void) {
    check(FOG_ABI_CHECK() == FOG_OK, "FOG_ABI_CHECK on this build", 0, 0);
    FogResult other = fog_abi_check(sizeof(FogModel) - 8, sizeof(FogUnit), sizeof(FogState),
                                    sizeof(FogPrediction), 140, FOG_MAX_INPUTS, FOG_MAX_MONOMIALS,
                                    FOG_UNIT_MAX_CHANNELS, FOG_UNIT_NUMBERS);
    check(other == FOG_ERR_ABI, "a header edited to 140 centres is told", (long)other, 0);
    check(sizeof(FogResult) == 4 && sizeof(FogStatus) == 4, "32-bit enums",
          (long)sizeof(FogResult), (long)sizeof(FogStatus));
}

static void decode_failures(void) {
    FogPrediction p;
    check(fog_state_reset(&state) == FOG_OK, "state reset", 0, 0);
    const uint8_t *blobs[3] = {NULL, blob, blob};
    size_t lens[3] = {blob_len, 10, blob_len - 1};
    for (int k = 0; k < 3; k++) {
        check(fog_model_decode(&model, blob, blob_len) == FOG_OK, "decode", k, 0);
        FogResult r = fog_model_decode(&model, blobs[k], lens[k]);
        check(r != FOG_OK, "a bad decode is refused", k, (long)r);
        r = fog_compensate(&model, &state, 60.0, 25.0f, 0.38f, &p);
        check(r == FOG_ERR_NO_MODEL, "a bad decode leaves no model", k, (long)r);
    }
}

static void layouts(void) {
    /* Wrong layouts on a 16 KiB device of 4 KiB sectors: each refused, nothing touched. */
    const FogLayout bad[] = {
        {0, SECTOR, 0},              {0, 5000, 5000},
        {0, SECTOR, 4095},           {0, SECTOR, 6000},
        {100, SECTOR, SECTOR},       {0, SECTOR + 4, SECTOR},
        {1, 2 * SECTOR, SECTOR},     {0, 0, SECTOR},
        {0, SECTOR, 2 * SECTOR},     {2 * SECTOR, SECTOR, 2 * SECTOR},
        {SECTOR, 0, 2 * SECTOR},     {0, SIZE, SECTOR},
        {0, 3 * SECTOR, 2 * SECTOR}, {SIZE, 0, SECTOR},
        {0, SECTOR, SIZE},           {0xFFFFF000u, 0, SECTOR},
        {0, 0xFFFFF000u, SECTOR},    {0, 0xFFFFE000u, 2 * SECTOR},
        {0, SECTOR, 0xFFFFF000u},    {3 * SECTOR, 2 * SECTOR, 2 * SECTOR},
        {0, 2 * SECTOR, 3 * SECTOR}, {2 * SECTOR, 2 * SECTOR, SECTOR},
    };
    size_t n = sizeof bad / sizeof bad[0];
    check(n == 22, "22 layouts", (long)n, 0);
    for (size_t k = 0; k < n; k++) {
        memcpy(&snapshot, &dev, sizeof dev);
        arm(-1, -1);
        FogResult r = update(&bad[k]);
        check(r == FOG_ERR_LAYOUT, "a wrong layout is refused", (long)k, (long)r);
        check(dev.ops == 0 && memcmp(dev.cells, snapshot.cells, SIZE) == 0,
              "nothing touched for a wrong layout", (long)k, dev.ops);
        long b = boot(&bad[k]);
        check(b == -(long)FOG_ERR_LAYOUT && !has_model(), "a wrong layout boots nothing",
              (long)k, b);
    }
}

/* Every operation of an update failing once, then the power cut at every `step`-th byte of its
 * work: the next boot has the model before the update or the one it wrote. */
static void failing_driver(long step) {
    for (long before = 1; before <= 2; before++) {
        memset(&dev, 0, sizeof dev);
        memset(dev.cells, 0xFF, SIZE);
        for (long k = 1; k <= before; k++) {
            arm(-1, -1);
            check(update(&LAYOUT) == FOG_OK, "the updates before", k, 0);
        }
        memcpy(&snapshot, &dev, sizeof dev);
        arm(-1, -1);
        check(update(&LAYOUT) == FOG_OK, "the clean update", before, 0);
        long ops = dev.ops, work_bytes = dev.worked;
        for (long fail = 0; fail < ops; fail++) {
            for (long cut = 0; cut <= work_bytes; cut += (cut + step > work_bytes && cut < work_bytes)
                                                         ? work_bytes - cut
                                                         : step) {
                memcpy(&dev, &snapshot, sizeof dev);
                arm(fail, cut);
                FogResult written = update(&LAYOUT);
                cases++;
                arm(-1, -1);
                long b = boot(&LAYOUT);
                check(b == before || b == before + 1, "old or new model after a failure and a cut",
                      fail * 100000 + cut, b);
                if (written == FOG_OK) {
                    check(b == before + 1, "a finished update boots the new model", fail, cut);
                }
            }
        }
    }
    /* A boot whose read of either slot fails says so; tried again, it boots the newest. */
    for (long fail = 0; fail < 2; fail++) {
        check(fog_model_decode(&model, blob, blob_len) == FOG_OK, "decode", fail, 0);
        arm(fail, -1);
        long b = boot(&LAYOUT);
        check(b == -(long)FOG_ERR_FLASH_DEVICE && !has_model(), "a failed read boots nothing",
              fail, b);
        arm(-1, -1);
        check(boot(&LAYOUT) == 3, "booted again, the newest", fail, 0);
    }
}

/* Compensates one sample a second for n seconds from t0 on a slow ramp; the last status. */
static FogStatus ramp(double t0, float temp0, int n) {
    FogPrediction p = {0};
    for (int k = 0; k < n; k++) {
        check(fog_compensate(&model, &state, t0 + k, temp0 + 0.01f * k, 0.38f, &p) == FOG_OK,
              "compensate", k, 0);
    }
    return p.status;
}

static void clock_back(void) {
    check(fog_model_decode(&model, blob, blob_len) == FOG_OK, "decode", 0, 0);
    check(fog_state_reset(&state) == FOG_OK, "reset", 0, 0);
    check(ramp(1000.0, 25.0f, 100) == FOG_VALID, "valid before", 0, 0);
    check(fog_state_power_on(&state) == FOG_OK, "power on", 0, 0);
    /* Time since power-on, where a clock that ran through the power-off was wanted. */
    check(ramp(0.5, 26.0f, 1) == FOG_DEGRADED, "a clock that went back is flagged", 0, 0);
    check(ramp(1.5, 26.0f, 999) == FOG_VALID, "valid once settled", 0, 0);
    /* A power-on with no time off at all: the clock did not run either. */
    check(fog_state_power_on(&state) == FOG_OK, "power on", 0, 0);
    check(ramp(999.5, 36.0f, 1) == FOG_DEGRADED, "a power-on without a time off is flagged", 0, 0);
}

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: fog_selftest model.bin [step]\n");
        return 1;
    }
    long step = argc > 2 ? strtol(argv[2], NULL, 10) : 1;
    FILE *f = fopen(argv[1], "rb");
    if (!f) {
        fprintf(stderr, "fog_selftest: cannot open %s\n", argv[1]);
        return 1;
    }
    blob_len = fread(blob, 1, sizeof blob, f);
    fclose(f);
    abi();
    decode_failures();
    memset(dev.cells, 0xFF, SIZE);
    layouts();
    failing_driver(step < 1 ? 1 : step);
    clock_back();
    printf("fog_selftest: %ld checks, %ld failed (%ld updates with a failure and a cut)\n", checks,
           failures, cases);
    return failures == 0 ? 0 : 1;
}
