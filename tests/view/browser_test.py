#!/usr/bin/env python3
"""peis view in a real browser.

Starts a test ecology of `peis node` processes (a sensor, a lamp wired to
it by a meta tuple, a PEIS that takes at most 64 bytes a value, a camera
with a raw image), runs `peis view` through the `peis` tool, and drives
headless Chromium (Debian's chromium and chromium-driver) with Selenium:
the page loads and lists the PEIS; a tuple written by another process
changes on the page within a second; an edit made on the page reaches the
owner; a bad edit shows the owner's error; the camera's image shows as a
picture; the browser logs no error. With --configurator, a real
meta-level runs too (peis-configurator and peis-synthetic producers and a
consumer): a goal posted as a tuple is planned and deployed, and the page
shows the configurator's own tuples (config.goal.*, config.goal-status,
config.deployed, config.owned, the config.event.* log) and the deployed
link in the graph. Screenshots go to --screenshots; view.png is the one
docs/images/view.png is taken from.

Exit status 0 when all holds, 1 when something does not, 77 (skipped) when
the browser or Selenium is not installed (./run test installs them).
Every wait has a deadline; every process started here is ended by its pid.
"""

import argparse
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

DEADLINE = 30.0  # seconds for anything that only has to happen eventually
LIVE = 1.0       # seconds: a change must show on the page within this


class Failure(Exception):
    pass


def wait_for(what, condition, deadline=DEADLINE, interval=0.05):
    """Polls condition() until it returns a true value; fails at the deadline."""
    until = time.monotonic() + deadline
    while True:
        try:
            value = condition()
        except Exception as e:  # an element the live page replaced meanwhile: ask again
            if type(e).__name__ != "StaleElementReferenceException":
                raise
            value = None
        if value:
            return value
        if time.monotonic() >= until:
            raise Failure("timed out after %.1f s waiting for %s" % (deadline, what))
        time.sleep(interval)


class Ecology:
    """The processes of the test; each ended by its pid."""

    def __init__(self, peis, view, ecology, workdir):
        self.peis = peis
        self.workdir = workdir
        self.env = dict(os.environ)
        self.env.setdefault("PEIS_DISCOVERY_SCOPE", "loopback")
        self.env["PEIS_ECOLOGY"] = ecology
        self.env["PEIS_EXEC_PATH"] = os.path.dirname(view)
        self.env.pop("PEIS_LOG", None)
        self.processes = []

    def start(self, name, args, program=None):
        out = open(os.path.join(self.workdir, name + ".out"), "w+")
        err = open(os.path.join(self.workdir, name + ".err"), "w+")
        env = dict(self.env)
        if args[0] == "node" or program:
            env["PEIS_LOG"] = "info"
        process = subprocess.Popen([program or self.peis] + args, stdout=out, stderr=err,
                                   stdin=subprocess.DEVNULL, env=env)
        self.processes.append((name, process, out, err))
        return process, out, err

    def node(self, name, *flags):
        _, _, err = self.start(name, ["node", "--peis-name", name] + list(flags))

        def started():
            err.seek(0)
            match = re.search(r"peis node: PEIS (\d+) '[^']*' on port (\d+)", err.read())
            return int(match.group(1)) if match else None

        return wait_for("PEIS %s to start" % name, started)

    def program(self, name, program, *flags):
        """Starts another program as PEIS `name`; returns its id once it is reachable."""
        self.start(name, ["--peis-name", name] + list(flags), program=program)
        return self.peis_id(name)

    def peis_id(self, name):
        def listed():
            for peer in json.loads(self.run("ls", "--json", "--wait", "1") or "[]"):
                if peer.get("name") == name:
                    return peer["id"]
            return None

        return wait_for("PEIS %s to join" % name, listed)

    def run(self, *args):
        result = subprocess.run([self.peis] + list(args), env=self.env, capture_output=True,
                                text=True, timeout=60)
        if result.returncode != 0:
            raise Failure("peis %s: exit %d: %s" % (" ".join(args), result.returncode,
                                                    result.stderr.strip()))
        return result.stdout

    def view(self):
        _, out, _ = self.start("view", ["view", "--port", "0"])

        def url():
            out.seek(0)
            match = re.search(r"peis view: (http://127\.0\.0\.1:\d+/)", out.read())
            return match.group(1) if match else None

        return wait_for("peis view to print its URL", url)

    def stop(self):
        for name, process, out, err in self.processes:
            if process.poll() is None:
                process.send_signal(signal.SIGTERM)
        for name, process, out, err in self.processes:
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
            out.close()
            err.close()

    def logs(self):
        text = ""
        for name, process, out, err in self.processes:
            for stream, label in ((out, "stdout"), (err, "stderr")):
                stream.seek(0)
                content = stream.read()[-3000:]
                if content:
                    text += "--- %s %s ---\n%s\n" % (name, label, content)
        return text


def browser(webdriver, Service, chromium, chromedriver, profile):
    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for flag in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync",
                 "--disable-dev-shm-usage", "--window-size=1600,1250"):
        options.add_argument(flag)
    options.add_argument("--user-data-dir=" + profile)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(chromedriver), options=options)
    driver.set_page_load_timeout(60)
    return driver


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--peis", required=True, help="the peis tool")
    parser.add_argument("--view", required=True, help="the peis-view program")
    parser.add_argument("--screenshots", required=True, help="folder for the screenshots")
    parser.add_argument("--configurator", help="peis-configurator: also run a meta-level")
    parser.add_argument("--synthetic", help="peis-synthetic, for the meta-level's components")
    parser.add_argument("--descriptors", help="the folder of tests/meta/descriptors")
    args = parser.parse_args()

    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
        from selenium.webdriver.common.by import By
        from selenium.common.exceptions import (ElementClickInterceptedException,
                                                StaleElementReferenceException)
    except ImportError:
        print("skipped: python3-selenium is not installed (./run test installs it)")
        return 77
    chromium = shutil.which("chromium") or "/usr/bin/chromium"
    chromedriver = shutil.which("chromedriver") or "/usr/bin/chromedriver"
    for path, package in ((chromium, "chromium"), (chromedriver, "chromium-driver")):
        if not os.access(path, os.X_OK):
            print("skipped: %s is not installed (./run test installs it)" % package)
            return 77

    os.makedirs(args.screenshots, exist_ok=True)
    workdir = tempfile.mkdtemp(prefix="peis-view-browser-")
    ecology = Ecology(args.peis, args.view, "it-view-browser-%d" % os.getpid(), workdir)
    driver = None
    try:
        sensor = ecology.node("sensor", "--peis-set-tuple", "brightness=40")
        lamp = ecology.node("lamp", "--peis-set-tuple", "light=off")
        # The owner of the bad edit below. (No small --peis-max-data here: a
        # PEIS with a small limit refuses to relay big frames, and may be on
        # a route before the direct links are up.)
        small = ecology.node("small")
        camera = ecology.node("camera")
        ecology.run("meta", "lamp.mi-brightness", "sensor.brightness")
        width, height = 64, 48
        frame = bytearray()
        for y in range(height):
            for x in range(width):
                frame += bytes((x * 4 % 256, y * 5 % 256, 200))  # B, G, R
        raw = os.path.join(workdir, "frame.raw")
        with open(raw, "wb") as f:
            f.write(frame)
        ecology.run("set", "camera.image", "@" + raw, "--mimetype",
                    "image/x-raw;format=bgr8;width=%d;height=%d" % (width, height))
        meta = None
        if args.configurator:
            def synthetic(name, descriptor):
                return ecology.program(name, args.synthetic, "--descriptor",
                                       os.path.join(args.descriptors, descriptor),
                                       "--period-ms", "200", "--freshness-ms", "1500")

            meta = {"pa": synthetic("pa", "position-cheap.yaml"),
                    "pb": synthetic("pb", "position-dear.yaml"),
                    "c1": synthetic("c1", "consumer.yaml"),
                    "cfg": ecology.program("cfg", args.configurator)}
            wait_for("the configurator to be active",
                     lambda: ecology.run("get", "cfg.config.configurator", "--wait", "5").strip() == "active")
        url = ecology.view()
        print("view at", url)

        driver = browser(webdriver, Service, chromium, chromedriver,
                         tempfile.mkdtemp(prefix="profile-", dir=workdir))
        driver.get(url)

        def shot(name):
            path = os.path.join(args.screenshots, name)
            driver.save_screenshot(path)
            print("screenshot", path)

        def text_of(selector):
            # None when absent, or when the page replaced the element between
            # finding and reading it (a live page does): the wait asks again.
            try:
                found = driver.find_elements(By.CSS_SELECTOR, selector)
                return found[0].text if found else None
            except StaleElementReferenceException:
                return None

        def click(what, selector):
            """Clicks a button of a live table: brought to the middle of its
            scrolling box first (not under the table's header), and found again
            when the page replaced it or something covered it meanwhile."""
            def clicked():
                found = driver.find_elements(By.CSS_SELECTOR, selector)
                if not found:
                    return False
                try:
                    driver.execute_script("arguments[0].scrollIntoView({block: 'center'});", found[0])
                    found[0].click()
                    return True
                except (StaleElementReferenceException, ElementClickInterceptedException):
                    return False

            wait_for(what, clicked)

        # The page loads and lists the PEIS of the ecology.
        wait_for("the page to connect", lambda: text_of("#connection") == "live")
        for name, ident in (("sensor", sensor), ("lamp", lamp), ("small", small), ("camera", camera)):
            wait_for("PEIS %s (%d) in the PEIS table" % (name, ident),
                     lambda: (text_of('#peis tr[data-peis="%d"]' % ident) or "").find(name) >= 0)
            wait_for("PEIS %s in the graph" % name,
                     lambda: driver.find_elements(By.CSS_SELECTOR, '#graph g[data-peis="%d"]' % ident))
        wait_for("the configuration link lamp.mi-brightness <- sensor.brightness",
                 lambda: "sensor.brightness" in (text_of('#configuration tr[data-tuple="%d.mi-brightness"]' % lamp) or ""))
        shot("loaded.png")

        # A tuple written by another process changes on the page within a second.
        cell = '#tuples tr[data-tuple="%d.brightness"] td.value' % sensor
        wait_for("sensor.brightness = 40 on the page", lambda: text_of(cell) == "40")
        shown = False
        for attempt, value in enumerate(("17", "18", "19")):
            ecology.run("set", "sensor.brightness", value)
            accepted = time.monotonic()
            try:
                wait_for("sensor.brightness = %s on the page" % value,
                         lambda: text_of(cell) == value, deadline=LIVE, interval=0.02)
                print("the change showed %.0f ms after the owner accepted it"
                      % ((time.monotonic() - accepted) * 1000))
                shown = True
                break
            except Failure as failure:
                # A loaded machine may miss once; three misses fail the test.
                print("attempt %d: %s" % (attempt + 1, failure), file=sys.stderr)
        if not shown:
            raise Failure("no change of sensor.brightness showed on the page within %.1f s" % LIVE)

        # An edit made on the page reaches the owner.
        click("lamp.light's edit button", '#tuples tr[data-tuple="%d.light"] button.edit' % lamp)
        wait_for("the edit form to hold lamp.light's value",
                 lambda: driver.find_element(By.ID, "edit-value").get_attribute("value") == "off")
        value_box = driver.find_element(By.ID, "edit-value")
        value_box.clear()
        value_box.send_keys("on")
        driver.find_element(By.ID, "edit-set").click()
        wait_for("the edit to be accepted", lambda: (text_of("#edit-result") or "").startswith("accepted"))
        wait_for("the lamp to hold light = on",
                 lambda: ecology.run("get", "lamp.light", "--wait", "5").strip() == "on")
        wait_for("lamp.light = on in the table",
                 lambda: text_of('#tuples tr[data-tuple="%d.light"] td.value' % lamp) == "on")
        shot("edit.png")

        # A bad edit shows the owner's error.
        name_box = driver.find_element(By.ID, "edit-name")
        name_box.clear()
        name_box.send_keys("small.kernel.note")  # kernel.* is the owner's own
        value_box.clear()
        value_box.send_keys("x")
        driver.find_element(By.ID, "edit-set").click()
        error = wait_for("the owner's refusal on the page",
                         lambda: (text_of("#edit-result") or "") if "refused" in (text_of("#edit-result") or "") else None)
        if ("PEIS %d" % small) not in error:
            raise Failure("the refusal does not name the owner PEIS %d: %r" % (small, error))
        print("the page shows:", error)
        shot("bad-edit.png")

        # The camera's raw image as a picture; a numeric tuple as a plot.
        wait_for("the camera's picture",
                 lambda: driver.execute_script(
                     "const i = document.querySelector('#images figure[data-tuple=\"%d.image\"] img');"
                     "return i && i.complete && i.naturalWidth === %d;" % (camera, width)))
        click("sensor.brightness's plot button",
              '#tuples tr[data-tuple="%d.brightness"] button.plot' % sensor)
        for value in ("25", "31", "22"):
            ecology.run("set", "sensor.brightness", value)
        wait_for("the plot's title", lambda: text_of("#plot-name") == "%d.brightness" % sensor)

        if meta:
            # A goal posted as a tuple: the real configurator plans and deploys
            # it, and the page shows the configurator's tuples as they come.
            cfg, c1 = meta["cfg"], meta["c1"]
            # Before the goal: the consumer waits for `position`, in amber.
            consumer = '#peis tr[data-peis="%d"]' % c1
            wait_for("c1 waiting (amber badge) and missing position",
                     lambda: driver.find_elements(By.CSS_SELECTOR, consumer + " .badge.waiting")
                     and "position" in (text_of(consumer + " td.causes") or ""))
            ecology.run("set", "cfg.config.goal.view", "position@c1.mi-position\n")

            def meta_row(owner, key):
                return text_of('#meta-rows tr[data-tuple="%d.%s"]' % (owner, key)) or ""

            wait_for("the goal tuple in the meta-level panel",
                     lambda: "position@c1.mi-position" in meta_row(cfg, "config.goal.view"))
            wait_for("the configurator's answer 'deployed' in the meta-level panel",
                     lambda: "deployed" in meta_row(cfg, "config.goal-status"))
            # The producer is the configurator's choice (pa is the cheaper one; the
            # view shows whichever it deployed).
            producer = wait_for("the deployed configuration in the meta-level panel",
                                lambda: next((p for p in ("pa", "pb") if "c1.mi-position <- %s.position" % p
                                              in meta_row(cfg, "config.deployed")), None))
            print("the configurator deployed c1.mi-position <- %s.position" % producer)
            if producer != "pa":  # the dearer one: say what the configurator saw
                print("note: pb (cost 4) deployed, not pa (cost 2); the configurator's model:\n"
                      + ecology.run("get", "cfg.model.live", "--wait", "5"), file=sys.stderr)
            wait_for("the deployment's record on the consumer",
                     lambda: "mi-position" in meta_row(c1, "config.owned"))
            wait_for("the configurator's 'deployed' event in the event log",
                     lambda: re.search(r"cfg\.config\.event\.\d+ = deployed generation",
                                       text_of("#meta-log") or ""))
            wait_for("the deployed link c1.mi-position <- %s.position in the configuration" % producer,
                     lambda: ("%s.position" % producer) in
                     (text_of('#configuration tr[data-tuple="%d.mi-position"]' % c1) or ""))
            wait_for("c1 running (green badge)",
                     lambda: driver.find_elements(By.CSS_SELECTOR, consumer + " .badge.running"))
            print("the page shows the configurator's goal, answer, deployment and events")
            # The whole page in one picture, meta-level panel included.
            height = driver.execute_script("return document.documentElement.scrollHeight")
            wanted = min(max(int(height) + 40, 1250), 3000)
            driver.set_window_size(1600, wanted)
            wait_for("the window to take its new size",
                     lambda: driver.execute_script("return window.outerHeight") >= wanted - 2)
        shot("view.png")

        problems = [entry for entry in driver.get_log("browser")
                    if entry.get("level") == "SEVERE" and "favicon.ico" not in entry.get("message", "")]
        if problems:
            raise Failure("the browser logged errors: %s" % problems)
        print("ok: the page listed the PEIS, showed a change live, wrote an edit, showed the "
              "owner's refusal and the camera's picture")
        return 0
    except Exception as failure:  # a Failure, or Selenium's or a process's error
        print("FAILED:", type(failure).__name__, failure, file=sys.stderr)
        if driver is not None:
            try:
                driver.save_screenshot(os.path.join(args.screenshots, "failure.png"))
                print("--- page ---\n" + driver.find_element(By.TAG_NAME, "body").text[:4000], file=sys.stderr)
            except Exception as e:  # the browser may be gone
                print("no screenshot:", e, file=sys.stderr)
        print(ecology.logs(), file=sys.stderr)
        if args.configurator:  # what the meta-level saw
            config = os.path.join(os.path.dirname(args.configurator), "peis-config")
            for what in (["model"], ["events"]):
                try:
                    result = subprocess.run([config] + what, env=ecology.env, capture_output=True,
                                            text=True, timeout=60)
                    print("--- peis config %s ---\n%s%s" % (what[0], result.stdout, result.stderr[-2000:]),
                          file=sys.stderr)
                except Exception as e:
                    print("peis config %s: %s" % (what[0], e), file=sys.stderr)
        return 1
    finally:
        if driver is not None:
            driver.quit()
        ecology.stop()
        shutil.rmtree(workdir, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
