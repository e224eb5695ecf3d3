#!/usr/bin/env bash
# The firmware's budgets, enforced: exits with failure when one is exceeded.
#
#   firmware/budgets.sh [PRODUCTION_ELF BENCH_ELF]
#
# - Flash and static RAM of the production build (`cargo build --release`),
#   from llvm-size (rustup component llvm-tools): flash is what the linker puts
#   in FLASH (.vector_table + .text + .rodata, and .data's initial image),
#   static RAM is .data + .bss + .uninit.
# - Instructions per tick of the boot benchmark, in the `bench` build
#   (`cargo build --release --features bench`, src/bench.rs): qemu-run.sh boots
#   it under QEMU with the plugin qemu-insn-count.c (built here with cc)
#   counting the instructions between bench_start and bench_end; the first
#   BENCH_TICKS spans (src/bench.rs) are the benchmark's. Their median and their
#   worst tick (the cold first one) are checked.
# - RAM in all: static RAM plus the stack's high-water mark, of the same boot
#   of the bench build. The firmware measures the mark itself (src/stack.rs,
#   cortex-m-rt's paint-stack) and logs it when halted ("stack used N bytes"),
#   read here from its log decoded by defmt-print (`cargo install
#   defmt-print`). That boot is the firmware's deepest run: the benchmark
#   loads its calibration (every effect, the ranges) through the link's own
#   code, whose deepest path is the calibration's decoding, and runs its
#   ticks; the link served afterwards (qemu-link-test.sh) takes the same path
#   from a shallower caller.
#
# Without ELFs it builds both: the bench build first, copied to
# armcal-firmware-bench (both builds write armcal-firmware), then the
# production one. It prints every figure with its budget and each one exceeded
# as FAILED; exit code 0 when every budget is met, 1 when one is exceeded, 2
# when a figure could not be measured.
set -euo pipefail

# The budgets.
max_median_tick=5000 # instructions, the median tick of the boot benchmark
max_worst_tick=10000 # instructions, its most expensive tick
max_flash=65536      # bytes (64 KiB)
max_static_ram=16384 # bytes (16 KiB)
max_ram=65536        # bytes (64 KiB), static RAM + the stack's high-water mark

here=$(cd "$(dirname "$0")" && pwd)
error() {
    echo "budgets.sh: $*" >&2
    exit 2
}
if [[ $# -eq 2 ]]; then
    elf=$(realpath "$1")
    bench_elf=$(realpath "$2")
elif [[ $# -eq 0 ]]; then
    dir="${CARGO_TARGET_DIR:-$here/target}/thumbv7em-none-eabihf/release"
    (cd "$here" && cargo build --release --features bench)
    cp "$dir/armcal-firmware" "$dir/armcal-firmware-bench"
    (cd "$here" && cargo build --release)
    elf=$dir/armcal-firmware
    bench_elf=$dir/armcal-firmware-bench
else
    error "usage: budgets.sh [PRODUCTION_ELF BENCH_ELF]"
fi
[[ -f $elf ]] || error "no production ELF at $elf"
[[ -f $bench_elf ]] || error "no bench ELF at $bench_elf"
tools="$(rustc --print sysroot)/lib/rustlib/$(rustc -vV | sed -n 's/^host: //p')/bin"
# Each build is the one it is said to be.
symbols() { "$tools/llvm-nm" -C "$1"; }
if symbols "$elf" | grep -F ' armcal_firmware::bench::' >/dev/null; then
    error "$elf holds the boot benchmark: give the production build"
fi
symbols "$bench_elf" | grep -F ' armcal_firmware::bench::ticks::' >/dev/null ||
    error "$bench_elf holds no boot benchmark: give the build with --features bench"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
failed=0
# check NAME VALUE LIMIT UNIT
check() {
    if awk -v v="$2" -v l="$3" 'BEGIN { exit !(v > l) }'; then
        echo "budgets.sh: FAILED: $1 $2 $4 exceeds its budget of $3 $4" >&2
        failed=1
    else
        echo "$1 $2 $4, budget $3 $4: ok"
    fi
}

echo "== flash and static RAM of the production build ($elf)"
"$tools/llvm-size" -A "$elf" >"$work/size" || error "llvm-size failed on $elf"
section_sum() {
    awk -v list="$1" 'BEGIN { n = split(list, s, " "); for (i = 1; i <= n; i++) want[s[i]] = 1 }
        $1 in want { sum += $2 } END { print sum + 0 }' "$work/size"
}
grep -E '^(section|\.vector_table|\.text|\.rodata|\.data|\.bss|\.uninit) ' "$work/size"
flash=$(section_sum ".vector_table .text .rodata .data")
ram=$(section_sum ".data .bss .uninit")
check "flash (.vector_table + .text + .rodata + .data)" "$flash" "$max_flash" B
check "static RAM (.data + .bss + .uninit)" "$ram" "$max_static_ram" B

echo "== instructions per tick of the boot benchmark ($bench_elf)"
ticks=$(sed -n 's/^pub const BENCH_TICKS: u32 = \([0-9_]*\);.*/\1/p' "$here/src/bench.rs" | tr -d _)
[[ -n $ticks ]] || error "no BENCH_TICKS in src/bench.rs"
cc -shared -fPIC -O2 -Wall -o "$work/insn-count.so" "$here/qemu-insn-count.c"
symbol() {
    symbols "$bench_elf" | awk -v name="armcal_firmware::$1::" 'index($0, " " name) && !found++ { print "0x" $1 }'
}
start=$(symbol bench_start)
end=$(symbol bench_end)
[[ -n $start && -n $end ]] || error "no bench_start/bench_end symbols in $bench_elf"
# The same QEMU options as qemu-link-test.sh's counting run; the log is kept
# for the stack's high-water mark.
command -v defmt-print >/dev/null ||
    error "defmt-print not installed (cargo install defmt-print): the stack's high-water mark is read from the firmware's log"
"$here/qemu-run.sh" "$bench_elf" -icount shift=3 \
    -plugin "$work/insn-count.so,start=$start,end=$end" -d plugin -D "$work/insn-count.log" |
    tee "$work/bench.log" || error "the bench build did not boot and halt under QEMU"
sed -n 's/^insn-count: span [0-9]*: \([0-9]*\)$/\1/p' "$work/insn-count.log" | head -n "$ticks" >"$work/ticks"
spans=$(wc -l <"$work/ticks")
((spans == ticks)) || error "$spans spans counted, not the benchmark's $ticks"
read -r cold mean median worst worst_at < <(awk '
    { c[NR] = $1; s[NR] = $1; sum += $1; if ($1 > worst) { worst = $1; at = NR } }
    END {
        # Insertion sort of 200 values, for the median.
        for (i = 2; i <= NR; i++) { v = s[i]; for (j = i - 1; j >= 1 && s[j] > v; j--) s[j + 1] = s[j]; s[j + 1] = v }
        median = NR % 2 ? s[(NR + 1) / 2] : (s[NR / 2] + s[NR / 2 + 1]) / 2
        print c[1], int(sum / NR + 0.5), median, worst, at
    }' "$work/ticks")
echo "$ticks ticks: first (cold) $cold, mean $mean, median $median, worst $worst (tick $worst_at) instructions"
check "median tick" "$median" "$max_median_tick" instructions
check "worst tick" "$worst" "$max_worst_tick" instructions

echo "== static RAM and the stack's high-water mark of the same boot ($bench_elf)"
"$tools/llvm-size" -A "$bench_elf" >"$work/size" || error "llvm-size failed on $bench_elf"
bench_ram=$(section_sum ".data .bss .uninit")
stack=$(sed -n 's/.*halt: .*stack used \([0-9]*\) bytes.*/\1/p' "$work/bench.log" | tail -n 1)
[[ -n $stack ]] || error "no \"stack used N bytes\" in the bench build's halt log"
echo "static RAM $bench_ram B, stack high-water mark $stack B (the boot benchmark, then the halt)"
check "static RAM + stack high-water mark" "$((bench_ram + stack))" "$max_ram" B

if ((failed)); then
    echo "budgets.sh: FAILED: over budget" >&2
    exit 1
fi
echo "budgets.sh: every budget met"
