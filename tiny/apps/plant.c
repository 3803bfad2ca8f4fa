/* Plant (tiny PEIS 3): watches the sunlight on the plant and asks the blind
 * to close when it is too bright (<3, 43, "0">) and to open again when it is
 * dark (<3, 43, "100">), with hysteresis. Key 43 is TiltValue. */
#include "tiny_app.h"

#define PLANT_ID 3
#define PLANT_CLOSE_ABOVE 700 /* light level that harms the plant */
#define PLANT_OPEN_BELOW 300
#define PLANT_SAMPLE_MS 250u

static uint32_t last_sample_ms;
static int sampled;
static int tilt = -1; /* last TiltValue posted, -1 = none yet */

uint16_t app_default_id(void) { return PLANT_ID; }

static void post_tilt(tiny_kernel *k, int value) {
  if (tiny_set_long(k, TINY_KEY_TILT_VALUE, value) == TINY_OK) {
    tilt = value;
    tiny_port_report("plant tilt", value);
  }
}

void app_setup(tiny_kernel *k) { (void)k; }

void app_loop(tiny_kernel *k, uint32_t now_ms) {
  long light;
  if (sampled && (uint32_t)(now_ms - last_sample_ms) < PLANT_SAMPLE_MS) return;
  sampled = 1;
  last_sample_ms = now_ms;
  light = tiny_port_sensor(TINY_SENSOR_LIGHT);
  if (light > PLANT_CLOSE_ABOVE && tilt != 0) {
    tiny_port_report("plant light", light);
    post_tilt(k, 0);
  } else if (light < PLANT_OPEN_BELOW && tilt != 100) {
    tiny_port_report("plant light", light);
    post_tilt(k, 100);
  }
}
