/* Parcel (tiny PEIS 5): publishes its weight (key 44, grams as decimal
 * text) when it changes by more than a few grams, and at least every 10 s
 * as a heartbeat of the value. */
#include "tiny_app.h"

#define PARCEL_ID 5
#define PARCEL_SAMPLE_MS 500u
#define PARCEL_REFRESH_MS 10000u
#define PARCEL_DEADBAND 5 /* grams */

static uint32_t last_sample_ms, last_post_ms;
static int posted;
static long weight;

uint16_t app_default_id(void) { return PARCEL_ID; }

void app_setup(tiny_kernel *k) { (void)k; }

void app_loop(tiny_kernel *k, uint32_t now_ms) {
  long w, diff;
  if (posted && (uint32_t)(now_ms - last_sample_ms) < PARCEL_SAMPLE_MS) return;
  last_sample_ms = now_ms;
  w = tiny_port_sensor(TINY_SENSOR_WEIGHT);
  diff = w > weight ? w - weight : weight - w;
  if (posted && diff <= PARCEL_DEADBAND && (uint32_t)(now_ms - last_post_ms) < PARCEL_REFRESH_MS)
    return;
  if (tiny_set_long(k, TINY_KEY_WEIGHT, w) == TINY_OK) {
    posted = 1;
    weight = w;
    last_post_ms = now_ms;
    tiny_port_report("parcel weight", w);
  }
}
