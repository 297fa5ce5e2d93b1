// Where the phone is, for the sun: arlightd places the sun from the latitude, longitude and time
// (the Location message), sent only when the page's user ticks "the sun from my location" and
// the browser's own prompt agrees, and again after every Welcome (controls.js and app.js wire it).
import { showError, state } from './status.js';

export class Place {
  constructor(client) {
    this.client = client;
    this.place = null;  // {latitude, longitude, altitude, utc (s), at (performance.now(), ms)}
    this.onPlace = () => {};  // once the browser gave it
  }

  /** Asks the browser (it asks its user); state.geolocation follows. */
  ask() {
    if (!navigator.geolocation) {
      state.geolocation = 'unavailable';
      showError('location: this browser has no geolocation');
      return;
    }
    state.geolocation = 'asked';
    navigator.geolocation.getCurrentPosition((p) => {
      this.place = { latitude: p.coords.latitude, longitude: p.coords.longitude,
        altitude: p.coords.altitude ?? 0, utc: Date.now() / 1000, at: performance.now() };
      state.geolocation = 'granted';
      this.onPlace();
    }, (e) => {
      state.geolocation = 'refused';
      showError(`location: ${e.message || e.code}`);
    }, { maximumAge: 600000, timeout: 30000 });
  }

  /** Sent no more (arlightd keeps what it had for this session). */
  forget() {
    this.place = null;
  }

  /** The Location message for now, or null (no place, or a server that takes none). */
  message() {
    if (!this.place) return null;
    const { latitude, longitude, altitude } = this.place;
    const utc = this.place.utc + (performance.now() - this.place.at) / 1000;
    return this.client.location(latitude, longitude, altitude, utc,
      state.orientation === 'absolute-orientation-sensor');
  }
}
