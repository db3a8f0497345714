#!/usr/bin/env bash
# Make sure Debian's Chromium is at /usr/bin/chromium (the browser tests drive it through
# playwright; `playwright install` cannot download here and is never used).
set -euo pipefail
if [ -x /usr/bin/chromium ]; then exit 0; fi
if [ "$(id -u)" = "0" ]; then
  echo "Installing Debian's chromium (needed by the browser tests)..." >&2
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq chromium fonts-dejavu-core >/dev/null
  [ -x /usr/bin/chromium ] || { echo "error: chromium did not install at /usr/bin/chromium" >&2; exit 1; }
else
  echo "error: /usr/bin/chromium is missing. Install it with: sudo apt-get install -y chromium" >&2
  exit 1
fi
