#!/usr/bin/env bash
# Boots the firmware under QEMU, halts it over the serial link and prints its
# defmt log.
#
#   ./qemu-run.sh [ELF [QEMU_ARG...]]
#
# Without ELF it builds the production release binary first. QEMU_ARGs are
# added to QEMU's command line (budgets.sh adds the instruction-counting
# plugin). QEMU's netduinoplus2 is an STM32F405 like the controller;
# semihosting carries the defmt frames to stdout and the firmware's exit code
# back. Once booted (at once in the production build, after the boot benchmark
# in the `bench` build) the firmware serves the link on USART1 (QEMU's first
# -serial), here a pair of FIFOs; this script writes the Halt request into it
# (the 3 bytes of armcal_shared::link::HALT_FRAME, checked by that crate's
# tests) and the firmware exits. The link itself is tested by
# qemu-link-test.sh. The log is decoded with defmt-print
# (`cargo install defmt-print`) when it is installed; otherwise the raw frames are
# kept in a file next to the ELF.
#
# Exit code: the firmware's (0 when it booted and halted, 1 on an error, panic
# or hard fault), 124 when it did not exit within QEMU_TIMEOUT seconds
# (default 60).
set -euo pipefail

extra=()
if [[ $# -ge 1 ]]; then
    elf=$(realpath "$1")
    extra=("${@:2}")
    cd "$(dirname "$0")"
else
    cd "$(dirname "$0")"
    cargo build --release
    elf="${CARGO_TARGET_DIR:-target}/thumbv7em-none-eabihf/release/armcal-firmware"
fi
[[ -f $elf ]] || { echo "qemu-run.sh: no firmware ELF at $elf" >&2; exit 2; }

# The link: QEMU reads link.in and writes link.out. QEMU's USART drops what
# arrives before the firmware turns it on, so the Halt request is repeated
# every half second until QEMU exits; a frame cut by the drop is refused by the
# firmware and the next one is read whole.
fifo_dir=$(mktemp -d)
halter=
cleanup() {
    [[ -n $halter ]] && kill "$halter" 2>/dev/null
    rm -rf "$fifo_dir"
}
trap cleanup EXIT
mkfifo "$fifo_dir/link.in" "$fifo_dir/link.out"
# Held open read-write here too, so that neither QEMU nor the writes block.
exec 3<>"$fifo_dir/link.in" 4<>"$fifo_dir/link.out"
qemu=(qemu-system-arm -cpu cortex-m4 -machine netduinoplus2 -display none -monitor none
      -chardev "pipe,id=link,path=$fifo_dir/link" -serial chardev:link
      -semihosting-config "enable=on,target=native" "${extra[@]}" -kernel "$elf")
timeout_s=${QEMU_TIMEOUT:-60}
# A lone 0x00 ends any partial frame, then the Halt request.
(for _ in $(seq $((timeout_s * 2))); do printf '\000\002\003\000' >&3; sleep 0.5; done) &
halter=$!

echo "qemu-run.sh: booting $elf (timeout ${timeout_s}s)"
if command -v defmt-print >/dev/null; then
    set +e
    timeout "$timeout_s" "${qemu[@]}" </dev/null | defmt-print -e "$elf"
    status=("${PIPESTATUS[@]}")
    set -e
    rc=${status[0]}
    if (( status[1] != 0 )); then
        echo "qemu-run.sh: defmt-print could not decode the log (exit ${status[1]})" >&2
    fi
else
    raw="$elf.defmt"
    set +e
    timeout "$timeout_s" "${qemu[@]}" </dev/null >"$raw"
    rc=$?
    set -e
    echo "qemu-run.sh: defmt-print not installed; $(wc -c <"$raw") bytes of raw defmt frames in $raw"
fi

case $rc in
    0) echo "qemu-run.sh: firmware exited with success" ;;
    124) echo "qemu-run.sh: firmware did not exit within ${timeout_s}s" >&2 ;;
    *) echo "qemu-run.sh: firmware exited with failure ($rc)" >&2 ;;
esac
exit "$rc"
