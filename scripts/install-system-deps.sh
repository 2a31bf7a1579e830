#!/usr/bin/env bash
# Installs the system packages the project needs:
# - the libLLVM that Dr.Jit 1.5 (Mitsuba's LLVM backend) needs. Debian's libllvm19 works;
#   libLLVM 15 crashes in `fminimum`, so anything older than 16 is not enough;
# - Node.js and npm, which run the Khronos glTF-Validator and playwright-core in the tests;
# - Chromium, in which a test opens sa-estimate's report (scripts/check_report.js).
set -euo pipefail
sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
    echo "Installing Node.js and npm (the tests run the glTF-Validator)..."
    $sudo apt-get update -qq
    $sudo apt-get install -y -qq nodejs npm
fi
if [ ! -x /usr/bin/chromium ]; then
    echo "Installing Chromium (a test opens the estimate's report in it)..."
    $sudo apt-get update -qq
    $sudo apt-get install -y -qq chromium
fi
if ls /usr/lib/*/libLLVM-1[6-9]*.so* /usr/lib/*/libLLVM-2[0-9]*.so* >/dev/null 2>&1 \
   || ls /usr/lib/*/libLLVM.so.1[6-9]* /usr/lib/*/libLLVM.so.2[0-9]* >/dev/null 2>&1; then
    exit 0
fi
echo "Installing libllvm19 (needed by Mitsuba's llvm_ad_rgb variant)..."
$sudo apt-get update -qq
$sudo apt-get install -y -qq libllvm19
