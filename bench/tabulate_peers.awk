#!/usr/bin/awk -f
# Tabulates the raw lines of run_peer_comparison.sh as Markdown: for every
# cell the median of the repetitions and their range, and PEIS's ratio of
# medians to each peer. Input lines:
#   rtt PIN SIZE SYSTEM p50 p90 p99
#   stream PIN SIZE SYSTEM delivered/s delivered written lost-or-coalesced
#   scale unpinned N peis seconds cpu% rss pss private
# (plain awk: no gawk extensions)

function add(key, value) { n[key]++; v[key, n[key]] = value }

function median(key,    i, j, t, m, a) {
  m = n[key]
  if (m == 0) return -1
  for (i = 1; i <= m; i++) a[i] = v[key, i]
  for (i = 2; i <= m; i++) {
    t = a[i]
    for (j = i - 1; j >= 1 && a[j] > t; j--) a[j + 1] = a[j]
    a[j + 1] = t
  }
  lo[key] = a[1]; hi[key] = a[m]
  return m % 2 ? a[(m + 1) / 2] : (a[m / 2] + a[m / 2 + 1]) / 2
}

function fmt(x, digits) {
  if (x < 0) return "—"
  if (x >= 1e6) return sprintf("%.2f M", x / 1e6)
  if (x >= 1e4) return sprintf("%.0f k", x / 1e3)
  return sprintf("%." digits "f", x)
}

function cell(key, digits,    m) {
  m = median(key)
  if (m < 0) return "—"
  if (n[key] == 1) return fmt(m, digits)
  return fmt(m, digits) " (" fmt(lo[key], digits) "–" fmt(hi[key], digits) ")"
}

function ratio(a, b) { return (a > 0 && b > 0) ? sprintf("%.2f×", a / b) : "—" }

function sizeName(s) { return s >= 1024 ? (s / 1024) " KiB" : s " B" }

{
  if ($1 == "rtt") { add("rtt50 " $2 " " $3 " " $4, $5); add("rtt99 " $2 " " $3 " " $4, $7) }
  else if ($1 == "stream") { add("rate " $2 " " $3 " " $4, $5); add("drop " $2 " " $3 " " $4, $8) }
  else if ($1 == "scale") {
    add("secs " $3, $5); add("cpu " $3, $6); add("rss " $3, $7); add("pss " $3, $8); add("own " $3, $9)
  }
}

END {
  split("pinned unpinned", pins, " ")
  title["pinned"] = "pinned (taskset -c 0: both processes on core 0)"
  title["unpinned"] = "unpinned"
  for (p = 1; p <= 2; p++) {
    pin = pins[p]
    print "### Round trip, " title[pin] " — p50 in µs"
    print ""
    print "| size | raw TCP (one write) | Cyclone DDS | ZeroMQ PUB/SUB | PEIS | PEIS p99 | PEIS / TCP | PEIS / Cyclone | PEIS / ZeroMQ |"
    print "|---|---|---|---|---|---|---|---|---|"
    split("16 1024 65536", sizes, " ")
    for (s = 1; s <= 3; s++) {
      size = sizes[s]; k = "rtt50 " pin " " size " "
      tcp = median(k "tcp"); dds = median(k "dds"); zmq = median(k "zmq"); peis = median(k "peis")
      printf "| %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", sizeName(size), cell(k "tcp", 1),
        cell(k "dds", 1), cell(k "zmq", 1), cell(k "peis", 1), cell("rtt99 " pin " " size " peis", 1),
        ratio(peis, tcp), ratio(peis, dds), ratio(peis, zmq)
    }
    print ""
    print "### One-way stream to one subscriber, " title[pin] " — distinct updates delivered per second"
    print ""
    print "| size | Cyclone DDS (keep-all) | ZeroMQ (no drop) | PEIS | PEIS / Cyclone | PEIS / ZeroMQ | PEIS coalesced | peers lost |"
    print "|---|---|---|---|---|---|---|---|"
    split("16 1024", ssizes, " ")
    for (s = 1; s <= 2; s++) {
      size = ssizes[s]; k = "rate " pin " " size " "; d = "drop " pin " " size " "
      dds = median(k "dds"); zmq = median(k "zmq"); peis = median(k "peis")
      lost = (n[d "dds"] ? median(d "dds") : 0) + (n[d "zmq"] ? median(d "zmq") : 0)
      printf "| %s | %s | %s | %s | %s | %s | %s | %s |\n", sizeName(size), cell(k "dds", 0),
        cell(k "zmq", 0), cell(k "peis", 0), ratio(peis, dds), ratio(peis, zmq), cell(d "peis", 0),
        (lost > 0 ? fmt(lost, 0) : "0")
    }
    print ""
  }
  if (n["secs 200"] > 0) {
    print "### Scale — 200 PEIS processes on one host, unpinned"
    print ""
    print "| N | all N values seen (s) | idle CPU per PEIS (%) | RSS per PEIS (KiB) | PSS (KiB) | private (KiB) |"
    print "|---|---|---|---|---|---|"
    printf "| 200 | %s | %s | %s | %s | %s |\n", cell("secs 200", 2), cell("cpu 200", 3),
      cell("rss 200", 0), cell("pss 200", 0), cell("own 200", 0)
    print ""
  }
}
