/*
 * Reference vectors for tonegate's BT.2390 EETF, from libplacebo.
 *
 * Built and run by tests/bt2390/make_vectors.sh (which passes the version
 * pkg-config reports as argv[1]); prints tests/bt2390/vectors.json on stdout.
 *
 * Every output value is libplacebo's own pl_tone_map_sample() with
 * function = &pl_tone_map_bt2390, evaluated once with input_scaling =
 * output_scaling = PL_HDR_NITS (inputs, parameters and outputs in cd/m2) and
 * once with PL_HDR_PQ (inputs, parameters and outputs as PQ signal values,
 * 0..1). libplacebo computes in float (f32) throughout; every float written
 * here is the exact value of an f32 (printed with %.17g of its double).
 *
 * Inputs are generated here without libplacebo: luminances log-spaced from
 * 1e-4 to 1e4 cd/m2 plus exact points, rounded to f32; the PQ inputs are the
 * SMPTE ST 2084 inverse EOTF of those f32 luminances evaluated in double and
 * rounded to f32, except that 0 cd/m2 is PQ 0 (the PQ EOTF maps every signal
 * up to c1^m2 = 7.3e-7 to 0 cd/m2, and libplacebo's own conversion maps 0 to
 * 0 both ways).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <libplacebo/config.h>
#include <libplacebo/colorspace.h>
#include <libplacebo/tone_mapping.h>

#define LOG_POINTS 189

static const double EXACT[] = {
    0.0, 0.001, 0.005, 0.01, 0.05, 0.1, 0.5, 1.0, 5.0, 10.0, 18.0, 50.0, 80.0,
    100.0, 150.0, 200.0, 203.0, 300.0, 500.0, 600.0, 800.0, 1000.0, 1500.0,
    2000.0, 4000.0, 10000.0,
};
#define N_EXACT (sizeof(EXACT) / sizeof(EXACT[0]))

/* SMPTE ST 2084 inverse EOTF (cd/m2 -> signal), in double. */
static double pq_oetf(double nits)
{
    const double m1 = 2610.0 / 16384.0, m2 = 2523.0 / 4096.0 * 128.0;
    const double c1 = 3424.0 / 4096.0, c2 = 2413.0 / 4096.0 * 32.0,
                 c3 = 2392.0 / 4096.0 * 32.0;
    if (nits <= 0.0)
        return 0.0;
    double y = pow(nits / 10000.0, m1);
    return pow((c1 + c2 * y) / (1.0 + c3 * y), m2);
}

static int cmp_float(const void *a, const void *b)
{
    float x = *(const float *) a, y = *(const float *) b;
    return (x > y) - (x < y);
}

static void print_float(float v)
{
    if (!isfinite(v)) {
        fprintf(stderr, "harness: non-finite value %g\n", v);
        exit(1);
    }
    printf("%.17g", (double) v);
}

static void print_array(const float *v, int n)
{
    putchar('[');
    for (int i = 0; i < n; i++) {
        if (i)
            putchar(',');
        print_float(v[i]);
    }
    putchar(']');
}

struct levels {
    const char *name;
    const char *note;
    double in_min, in_max, out_min, out_max; /* cd/m2 */
};

static const struct levels LEVELS[] = {
    {"hdr1000_to_sdr100", "HDR 1000 cd/m2 to SDR 100 cd/m2, both blacks 0",
     0.0, 1000.0, 0.0, 100.0},
    {"hdr1000_to_sdr100_srcblack0.005",
     "source black 0.005 cd/m2 (a typical ST 2086 mastering minimum), target black 0: "
     "minLum is negative, so the black-point term pulls the shadows down",
     0.005, 1000.0, 0.0, 100.0},
    {"hdr1000_to_sdr100_dstblack0.1",
     "target black 0.1 cd/m2 (a BT.1886-style display), source black 0: exercises the "
     "black-point lift",
     0.0, 1000.0, 0.1, 100.0},
    {"hdr1000_to_sdr100_blacks0.005_0.1", "source black 0.005, target black 0.1 cd/m2",
     0.005, 1000.0, 0.1, 100.0},
    {"hdr1000_to_hdr203", "HDR 1000 cd/m2 to HDR 203 cd/m2 peak, both blacks 0",
     0.0, 1000.0, 0.0, 203.0},
    {"hdr1000_to_hdr203_srcblack0.005", "source black 0.005 cd/m2, target black 0",
     0.005, 1000.0, 0.0, 203.0},
    {"hdr1000_to_hdr203_dstblack0.1", "source black 0, target black 0.1 cd/m2",
     0.0, 1000.0, 0.1, 203.0},
    {"hdr4000_to_hdr1000", "HDR 4000 cd/m2 to 1000 cd/m2, both blacks 0",
     0.0, 4000.0, 0.0, 1000.0},
    {"hdr10000_to_sdr100", "the full PQ range to SDR 100 cd/m2, both blacks 0",
     0.0, 10000.0, 0.0, 100.0},
};
#define N_LEVELS (sizeof(LEVELS) / sizeof(LEVELS[0]))

static const float KNEES[] = {0.5f, 1.0f};
static const char *const KNEE_NOTES[] = {
    "ITU-R BT.2390's knee: KS = 1.5 maxLum - 0.5",
    "libplacebo's default (param 0 means this): KS = 2 maxLum - 1",
};

static void print_params(const struct pl_tone_map_params *p)
{
    printf("\"input_min\":");
    print_float(p->input_min);
    printf(",\"input_max\":");
    print_float(p->input_max);
    printf(",\"output_min\":");
    print_float(p->output_min);
    printf(",\"output_max\":");
    print_float(p->output_max);
}

int main(int argc, char **argv)
{
    const char *version = argc > 1 ? argv[1] : "unknown";
    static float nits[LOG_POINTS + N_EXACT], pq[LOG_POINTS + N_EXACT],
                 out[LOG_POINTS + N_EXACT];
    int n = 0;

    for (int i = 0; i < LOG_POINTS; i++)
        nits[n++] = (float) pow(10.0, -4.0 + 8.0 * i / (LOG_POINTS - 1));
    for (size_t i = 0; i < N_EXACT; i++)
        nits[n++] = (float) EXACT[i];
    qsort(nits, n, sizeof(float), cmp_float);
    int m = 0;
    for (int i = 0; i < n; i++) {
        if (m == 0 || nits[i] != nits[m - 1])
            nits[m++] = nits[i];
    }
    n = m;
    for (int i = 0; i < n; i++)
        pq[i] = (float) pq_oetf(nits[i]);

    printf("{\"generator\":\"tests/bt2390/make_vectors.sh (tests/bt2390/harness.c)\"");
    printf(",\"libplacebo\":\"%s\",\"pl_api_ver\":%d", version, PL_API_VER);
    printf(",\"function\":\"%s\"", pl_tone_map_bt2390.name);
    printf(",\"function_scaling\":\"PL_HDR_PQ\"");
    printf(",\"param_min\":");
    print_float(pl_tone_map_bt2390.param_min);
    printf(",\"param_def\":");
    print_float(pl_tone_map_bt2390.param_def);
    printf(",\"param_max\":");
    print_float(pl_tone_map_bt2390.param_max);
    printf(",\"sdr_white_nits\":");
    print_float(PL_COLOR_SDR_WHITE);
    printf(",\"note\":\"pl_tone_map_sample(x, params) with function bt2390; each case is "
           "run in PL_HDR_NITS (input, levels and output in cd/m2) and in PL_HDR_PQ (input, "
           "levels and output as PQ signal). Output is clamped to [output_min, output_max] "
           "and input to [input_min, input_max] by libplacebo. All floats are exact f32 "
           "values; libplacebo computes in f32.\"");
    printf(",\"inputs\":{\"nits\":");
    print_array(nits, n);
    printf(",\"pq\":");
    print_array(pq, n);
    printf("},\"cases\":[");

    int first = 1;
    for (size_t l = 0; l < N_LEVELS; l++) {
        for (size_t k = 0; k < sizeof(KNEES) / sizeof(KNEES[0]); k++) {
            const struct levels *lv = &LEVELS[l];
            printf("%s{\"name\":\"%s_knee%s\"", first ? "" : ",", lv->name,
                   k == 0 ? "0.5" : "1.0");
            first = 0;
            printf(",\"note\":\"%s; %s\"", lv->note, KNEE_NOTES[k]);
            printf(",\"knee_offset\":");
            print_float(KNEES[k]);
            printf(",\"input_min_nits\":%.17g,\"input_max_nits\":%.17g", lv->in_min,
                   lv->in_max);
            printf(",\"output_min_nits\":%.17g,\"output_max_nits\":%.17g", lv->out_min,
                   lv->out_max);

            struct pl_tone_map_params p = {
                .function = &pl_tone_map_bt2390,
                .param = KNEES[k],
                .input_scaling = PL_HDR_NITS,
                .output_scaling = PL_HDR_NITS,
                .input_min = (float) lv->in_min,
                .input_max = (float) lv->in_max,
                .output_min = (float) lv->out_min,
                .output_max = (float) lv->out_max,
            };
            for (int i = 0; i < n; i++)
                out[i] = pl_tone_map_sample(nits[i], &p);
            printf(",\"nits\":{\"scaling\":\"PL_HDR_NITS\",");
            print_params(&p);
            printf(",\"output\":");
            print_array(out, n);
            printf("}");

            p.input_scaling = p.output_scaling = PL_HDR_PQ;
            p.input_min = (float) pq_oetf(lv->in_min);
            p.input_max = (float) pq_oetf(lv->in_max);
            p.output_min = (float) pq_oetf(lv->out_min);
            p.output_max = (float) pq_oetf(lv->out_max);
            for (int i = 0; i < n; i++)
                out[i] = pl_tone_map_sample(pq[i], &p);
            printf(",\"pq\":{\"scaling\":\"PL_HDR_PQ\",");
            print_params(&p);
            printf(",\"output\":");
            print_array(out, n);
            printf("}}");
        }
    }
    printf("]}\n");
    return 0;
}
