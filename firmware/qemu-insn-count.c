/*
 * qemu-insn-count.c: a QEMU TCG plugin that counts the guest instructions
 * executed between two marker functions, for firmware/qemu-link-test.sh.
 *
 *   cc -shared -fPIC -O2 -o insn-count.so qemu-insn-count.c
 *   qemu-system-arm ... -plugin ./insn-count.so,start=0xADDR,end=0xADDR \
 *       -d plugin -D insn-count.log
 *
 * start and end are the addresses of the firmware's `bench_start` and
 * `bench_end` (from the ELF's symbols; the Thumb bit is ignored). A span runs
 * from the first instruction of `bench_start` to the first of `bench_end`: the
 * marker's own few instructions, the call and return, and one correction. At
 * exit it prints each span's count, in order, then the number of spans and the
 * min, median, mean and max count. With profile=1 it also prints the
 * instructions executed inside the spans per translation-block address, to be
 * attributed to functions with the ELF's symbols (a development aid).
 *
 * Counting is per translation block: a block's instruction count is added when
 * it starts executing. A block runs whole unless a synchronous exception cuts
 * it (none in the firmware's correction); an interrupt taken inside a span (the
 * SysTick wrap, every 2^24 cycles) adds its handler's ~10 instructions.
 *
 * Debian's QEMU runs plugins but ships no qemu-plugin.h, so the few API
 * functions used are declared here, as QEMU 7.2's include/qemu/qemu-plugin.h
 * (API version 1) defines them.
 */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef uint64_t qemu_plugin_id_t;
typedef struct qemu_info_t qemu_info_t; /* not read */
struct qemu_plugin_tb;
enum qemu_plugin_cb_flags { QEMU_PLUGIN_CB_NO_REGS };
typedef void (*tb_trans_cb)(qemu_plugin_id_t id, struct qemu_plugin_tb *tb);
typedef void (*vcpu_udata_cb)(unsigned int vcpu_index, void *userdata);
typedef void (*udata_cb)(qemu_plugin_id_t id, void *userdata);

void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id, tb_trans_cb cb);
void qemu_plugin_register_vcpu_tb_exec_cb(struct qemu_plugin_tb *tb, vcpu_udata_cb cb,
                                          enum qemu_plugin_cb_flags flags, void *userdata);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *tb);
uint64_t qemu_plugin_tb_vaddr(const struct qemu_plugin_tb *tb);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t id, udata_cb cb, void *userdata);
void qemu_plugin_outs(const char *string);

__attribute__((visibility("default"))) int qemu_plugin_version = 1;

#define MAX_SPANS 100000
#define IS_START (1ull << 32)
#define IS_END (1ull << 33)

static uint64_t start_addr, end_addr;
/* profile=1: instructions per block start address inside the spans, printed at exit. */
#define PROFILE_SLOTS 65536
static bool profile;
static uint64_t prof_addr[PROFILE_SLOTS], prof_count[PROFILE_SLOTS];
static bool counting;
static uint64_t count;
static uint64_t spans[MAX_SPANS];
static size_t n_spans;

static void profile_add(uint64_t addr, uint64_t n)
{
    size_t i = (size_t)((addr >> 1) * 2654435761u) % PROFILE_SLOTS;
    while (prof_addr[i] != 0 && prof_addr[i] != addr) {
        i = (i + 1) % PROFILE_SLOTS;
    }
    prof_addr[i] = addr;
    prof_count[i] += n;
}

/* One block starts executing; userdata packs its instruction count and flags
 * (and, when profiling, its address in bits 34..63). */
static void tb_exec(unsigned int vcpu, void *userdata)
{
    uint64_t v = (uintptr_t)userdata;
    (void)vcpu;
    if (v & IS_END) {
        if (counting && n_spans < MAX_SPANS) {
            spans[n_spans++] = count;
        }
        counting = false;
    }
    if (v & IS_START) {
        counting = true;
        count = 0;
    }
    if (counting) {
        count += v & 0xffffffffu;
        if (profile) {
            profile_add((v >> 34) << 1, v & 0xffffffffu);
        }
    }
}

static void tb_trans(qemu_plugin_id_t id, struct qemu_plugin_tb *tb)
{
    uint64_t vaddr = qemu_plugin_tb_vaddr(tb);
    uint64_t v = qemu_plugin_tb_n_insns(tb);
    (void)id;
    if (vaddr == start_addr) {
        v |= IS_START;
    }
    if (vaddr == end_addr) {
        v |= IS_END;
    }
    v |= (vaddr >> 1) << 34;
    qemu_plugin_register_vcpu_tb_exec_cb(tb, tb_exec, QEMU_PLUGIN_CB_NO_REGS,
                                         (void *)(uintptr_t)v);
}

static int by_value(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static void at_exit(qemu_plugin_id_t id, void *userdata)
{
    char line[256];
    uint64_t sum = 0;
    (void)id;
    (void)userdata;
    if (n_spans == 0) {
        snprintf(line, sizeof line, "insn-count: no span between 0x%llx and 0x%llx\n",
                 (unsigned long long)start_addr, (unsigned long long)end_addr);
        qemu_plugin_outs(line);
        return;
    }
    for (size_t i = 0; i < n_spans; i++) {
        sum += spans[i];
        snprintf(line, sizeof line, "insn-count: span %zu: %llu\n", i + 1,
                 (unsigned long long)spans[i]);
        qemu_plugin_outs(line);
    }
    uint64_t first = spans[0];
    qsort(spans, n_spans, sizeof spans[0], by_value);
    for (size_t i = 0; profile && i < PROFILE_SLOTS; i++) {
        if (prof_addr[i] != 0) {
            snprintf(line, sizeof line, "insn-count: block 0x%llx: %llu\n",
                     (unsigned long long)prof_addr[i], (unsigned long long)prof_count[i]);
            qemu_plugin_outs(line);
        }
    }
    snprintf(line, sizeof line,
             "insn-count: %zu spans: first %llu, min %llu, median %llu, mean %llu, max %llu\n",
             n_spans, (unsigned long long)first, (unsigned long long)spans[0],
             (unsigned long long)spans[n_spans / 2], (unsigned long long)(sum / n_spans),
             (unsigned long long)spans[n_spans - 1]);
    qemu_plugin_outs(line);
}

__attribute__((visibility("default"))) int qemu_plugin_install(qemu_plugin_id_t id,
                                                               const qemu_info_t *info,
                                                               int argc, char **argv)
{
    (void)info;
    for (int i = 0; i < argc; i++) {
        if (strncmp(argv[i], "start=", 6) == 0) {
            start_addr = strtoull(argv[i] + 6, NULL, 0) & ~1ull;
        } else if (strcmp(argv[i], "profile=1") == 0) {
            profile = true;
        } else if (strncmp(argv[i], "end=", 4) == 0) {
            end_addr = strtoull(argv[i] + 4, NULL, 0) & ~1ull;
        } else {
            fprintf(stderr, "insn-count: unknown argument %s\n", argv[i]);
            return -1;
        }
    }
    if (start_addr == 0 || end_addr == 0) {
        fprintf(stderr, "insn-count: give start=ADDR,end=ADDR\n");
        return -1;
    }
    qemu_plugin_register_vcpu_tb_trans_cb(id, tb_trans);
    qemu_plugin_register_atexit_cb(id, at_exit, NULL);
    return 0;
}
